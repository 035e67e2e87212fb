"""A registered model served by ``mlflow models serve`` answers as ``bearingtwin-diagnose`` does.

Everything is real: smoke-size models are trained and registered by ``bearingtwin-train``
into temporary SQLite stores, ``mlflow models serve -m models:/<name>@<alias> --env-manager
local`` serves them on loopback ports, and windows of a CWRU record are posted to
``/invocations`` in the documented form ``{"inputs": [[...], ...], "params": {"rpm": ...}}`` (``"bearing"`` too).
The answers must be ``bearingtwin-diagnose``'s ``diagnosis.json`` for the same record, window
for window. Runs on ../shared/data/cwru (or $BEARINGTWIN_DATA/cwru).
"""

from __future__ import annotations

import json
import sys
import urllib.error
import urllib.request
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
from processes import (LOOPBACK, SMOKE, assert_done, child_env, free_loopback_port, kill_running_commands, run_module,
                       start, stop, wait_until_answers)

from bearingtwin.config import data_root
from bearingtwin.diagnosis.mlflow_model import (FEATURE_UNSEEN_COLUMN, LEVEL_UNSEEN_COLUMN, STATE_COLUMN,
                                                load_diagnosis_model)
from bearingtwin.diagnosis.record import diagnosed_windows, read_record

CWRU = data_root() / "cwru"
# 1 hp outer race, 12 kHz: the simulated-data models run at 10 kHz, so diagnose resamples it first
# and the posted windows must be the resampled ones.
RECORD = CWRU / "12k_Drive_End_OR007@6_1_131.mat"
needs_record = pytest.mark.skipif(not RECORD.is_file(), reason=f"CWRU record {RECORD.name} not found in {CWRU}")

MODEL_NAME = "served"
MODEL_ALIAS = "champion"
# Smallest runs (SMOKE) of the proposed CNN-BiLSTM and the SVM: two classifier files (network.pt, svm.json + svm.npz).
# Models whose features need rpm (features=envelope_orders) only train on data=twin_to_real, too slow here.
CASES = {"cnn_bilstm": ["trainer.max_epochs=2"], "svm": ["classifier=svm"]}

CHILD_TIMEOUT_S = 300  # a training or diagnose command; ~10 s each on 2 idle cores
SERVER_START_TIMEOUT_S = 120  # import + model load of a served model takes ~15 s on 2 idle cores
REQUEST_TIMEOUT_S = 60
PROBABILITY_TOLERANCE = 1e-6


def post_json(url: str, payload: dict) -> tuple[int, dict]:
    """HTTP status and decoded JSON body of a POST (error answers included, not raised)."""
    request = urllib.request.Request(url, data=json.dumps(payload).encode(), headers={"Content-Type": "application/json"})
    try:
        with LOOPBACK.open(request, timeout=REQUEST_TIMEOUT_S) as answer:
            return answer.status, json.load(answer)
    except urllib.error.HTTPError as error:
        body = error.read()
        try:
            return error.code, json.loads(body)
        except ValueError:
            return error.code, {"body": body.decode(errors="replace")}


@pytest.fixture(scope="module")
def served(tmp_path_factory):
    """Per case: the server's URL, ``bearingtwin-diagnose``'s diagnosis.json of RECORD, the loaded
    pipeline and RECORD's windows as diagnose cuts them.

    The two trainings run side by side (separate stores, no SQLite contention), then both servers
    start while ``bearingtwin-diagnose`` runs: on 2 cores this halves the wall time. The commands are
    forked from pre-imported servers (``run_module``); the model servers are started fresh, as a user would.
    """
    root = tmp_path_factory.mktemp("serve")
    cases = {}
    processes = []
    pool = ThreadPoolExecutor(max_workers=len(CASES))
    try:
        for case, overrides in CASES.items():
            folder = root / case
            folder.mkdir()
            store_uri = f"sqlite:///{folder / 'mlflow.db'}"
            env = child_env(store_uri)
            train = pool.submit(run_module, "bearingtwin.cli.train", *SMOKE, *overrides, f"register={MODEL_NAME}",
                                f"register_alias={MODEL_ALIAS}", cwd=folder, env=env, timeout=CHILD_TIMEOUT_S)
            cases[case] = {"folder": folder, "store_uri": store_uri, "env": env, "train": train}
        for case, info in cases.items():
            assert_done(info["train"].result(), f"bearingtwin-train ({case})")

        model_uri = f"models:/{MODEL_NAME}@{MODEL_ALIAS}"
        for case, info in cases.items():
            port = free_loopback_port()
            info["url"] = f"http://127.0.0.1:{port}"
            info["server_log"] = info["folder"] / "serve.log"
            info["server"] = start([sys.executable, "-m", "mlflow", "models", "serve", "-m", model_uri,
                                    "--env-manager", "local", "-h", "127.0.0.1", "-p", str(port)],
                                   info["env"], info["folder"], info["server_log"])
            processes.append(info["server"])
            info["diagnose"] = pool.submit(run_module, "bearingtwin.cli.diagnose", f"path={RECORD}", f"model={model_uri}",
                                           f"out={info['folder'] / 'diagnosis'}", "figures=false", "tracking.enabled=false",
                                           cwd=info["folder"], env=info["env"], timeout=CHILD_TIMEOUT_S)
        for info in cases.values():  # meanwhile, the windows as diagnose prepares them, from the registered model
            _, info["pipeline"], _ = load_diagnosis_model(model_uri, info["store_uri"])
            info["prepared"] = read_record(RECORD, info["pipeline"])  # DE channel, resampled to the model's rate
            info["windows"], info["starts"], *_ = diagnosed_windows(info["prepared"], info["pipeline"].window_length)
        for case, info in cases.items():
            assert_done(info["diagnose"].result(), f"bearingtwin-diagnose ({case})")
            info["diagnosis"] = json.loads((info["folder"] / "diagnosis" / RECORD.stem / "diagnosis.json").read_text())
            wait_until_answers(f"{info['url']}/ping", info["server"], info["server_log"], "mlflow models serve",
                               SERVER_START_TIMEOUT_S)
        yield cases
    finally:
        kill_running_commands()  # none when all went well; after a failure, the others need not finish
        pool.shutdown(cancel_futures=True)
        for process in processes:
            stop(process)


@needs_record
@pytest.mark.parametrize("case", list(CASES))
def test_served_model_answers_as_bearingtwin_diagnose(served, case):
    info = served[case]
    diagnosis, pipeline, prepared, windows = info["diagnosis"], info["pipeline"], info["prepared"], info["windows"]
    assert "resampled" in " ".join(diagnosis["notes"])  # 12 kHz record, 10 kHz model: the served windows are resampled
    assert windows.shape[0] == len(diagnosis["windows"]) > 1
    np.testing.assert_allclose(info["starts"] / prepared.recording.fs, [w["start_s"] for w in diagnosis["windows"]], atol=1e-9)

    status, answer = post_json(f"{info['url']}/invocations",
                               {"inputs": windows.tolist(), "params": {"rpm": prepared.recording.rpm}})
    assert status == 200, answer
    rows = answer["predictions"]
    assert len(rows) == len(diagnosis["windows"])
    names = pipeline.class_names
    for index, (row, expected) in enumerate(zip(rows, diagnosis["windows"])):
        # The smoke models' VMD features read the level and kept their training range.
        assert set(row) == {STATE_COLUMN, *names, LEVEL_UNSEEN_COLUMN, FEATURE_UNSEEN_COLUMN}
        # The record's windows stand at one level: each says what diagnose says of the record (a CWRU record is
        # louder than the smoke twin's windows by more than a decade).
        assert row[LEVEL_UNSEEN_COLUMN] is diagnosis["level_unseen"], f"window {index}"
        assert row[FEATURE_UNSEEN_COLUMN] == expected.get("feature_unseen", ""), f"window {index}"
        assert row[STATE_COLUMN] == expected["state"], f"window {index}"
        np.testing.assert_allclose([row[name] for name in names], [expected["probabilities"][name] for name in names],
                                   rtol=0, atol=PROBABILITY_TOLERANCE, err_msg=f"window {index}")


@needs_record
def test_served_model_refuses_a_wrong_window_length(served):
    info = next(iter(served.values()))
    pipeline = info["pipeline"]
    short = np.zeros((2, pipeline.window_length - 1)).tolist()
    # post_json's bounded timeout turns a hang into a failure.
    status, answer = post_json(f"{info['url']}/invocations", {"inputs": short, "params": {"rpm": 1797.0}})
    assert status == 400, answer  # the caller's input, not a server crash
    # The answer names the length the model reads, after MLflow's abridged echo of the request (its own refusal of a
    # shape had echoed all of it, tens of kB).
    assert answer["message"].endswith(f"Error: windows of {pipeline.window_length - 1} samples: the model reads windows "
                                      f"of {pipeline.window_length} samples at {pipeline.fs_hz:g} Hz, one a row; cut the "
                                      "record into such windows (bearingtwin-diagnose reads a whole record)"), answer
    assert len(answer["message"]) < 400, answer
    flat = np.ones((2, pipeline.window_length))
    flat[0] += np.random.default_rng(0).standard_normal(pipeline.window_length)
    status, answer = post_json(f"{info['url']}/invocations", {"inputs": flat.tolist(), "params": {"rpm": 1797.0}})
    assert status == 400 and "window 1 of the request is constant (every sample equal)" in answer["message"], answer


@needs_record
def test_served_model_takes_the_recorded_bearing_and_refuses_an_unknown_one(served):
    """``bearing`` is a parameter of the served signature; the paper's time-domain features do not depend on it,
    so another bearing's answer is the same, and a name with no conf/bearing file is refused, named."""
    info = next(iter(served.values()))
    windows = info["windows"][:3].tolist()
    rpm = info["prepared"].recording.rpm
    _, plain = post_json(f"{info['url']}/invocations", {"inputs": windows, "params": {"rpm": rpm}})
    status, other = post_json(f"{info['url']}/invocations", {"inputs": windows, "params": {"rpm": rpm, "bearing": "cwru_6203"}})
    assert status == 200 and other == plain, other
    status, answer = post_json(f"{info['url']}/invocations", {"inputs": windows, "params": {"rpm": rpm, "bearing": "skf_0000"}})
    # The reason in the answer's message, not only in its stack trace (MLflow's "unexpected error" for other exceptions).
    assert status == 400 and "params bearing=skf_0000: no such bearing config" in answer["message"], answer
    assert "hydra.searchpath" not in answer["message"]  # a request cannot give a command's search path
    status, answer = post_json(f"{info['url']}/invocations", {"inputs": windows, "params": {"rpm": -5.0}})
    assert status == 400 and "rpm=-5.0 must be a positive number of rev/min" in answer["message"], answer
