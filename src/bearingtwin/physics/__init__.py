"""The digital twin's physics: bearing geometry, contact dynamics, defects, effects and solvers."""
