"""Thin command-line entry points: they parse config, wire objects together and report errors."""
