"""``device = "auto"`` is the CPU path unless this machine's newest bench measured the CUDA fit
step faster and torch sees CUDA now (navbench.pipeline.devices); the key then names the device."""

from __future__ import annotations

import socket

import pytest
import torch

from navbench.pipeline.devices import measured_fit_devices, resolve_auto_fit_device
from navbench.pipeline.stages.context import StageContext
from navbench.pipeline.stages.maps import FitMapConfig, fit_key_settings, resolve_fit_device
from navbench.results.db import ResultsDB


@pytest.fixture
def db(tmp_path):
    return ResultsDB(f"sqlite:///{tmp_path / 'b.db'}")


def _bench(db, cpu_ms, cuda_ms, host=None):
    rid = db.start_run("bench", "bench", {}, "x")
    rows = [dict(metric="fit_step_ms", value=cpu_ms, unit="ms", device="cpu"),
            dict(metric="fit_step_ms", value=cuda_ms, unit="ms", device="cuda:0")]
    if host is not None:
        rows = [dict(r, host=host) for r in rows]
    db.add_bench_rows(rid, rows)
    return rid


def test_no_bench_no_database_or_a_slower_gpu_leave_auto_the_cpu_path(db, monkeypatch):
    monkeypatch.setattr(torch.cuda, "is_available", lambda: True)
    assert resolve_auto_fit_device(None)[0] == "auto"
    assert resolve_auto_fit_device(db) == ("auto", "auto: the CPU path (no bench of both fit paths on this machine)")
    _bench(db, 12.0, 14.5)
    device, why = resolve_auto_fit_device(db)
    assert device == "auto" and "14.50 ms a step on cuda:0, 12.00 on the CPU" in why


def test_a_faster_gpu_measured_on_this_host_is_chosen_while_torch_sees_it(db, monkeypatch):
    rid = _bench(db, 12.97, 1.44)
    _bench(db, 12.0, 0.5, host="another-machine")  # newer, but not this host's
    assert measured_fit_devices(db) == {"run_id": rid, "cpu_ms": 12.97, "cuda_ms": 1.44,
                                        "cuda_device": "cuda:0"}
    monkeypatch.setattr(torch.cuda, "is_available", lambda: False)
    device, why = resolve_auto_fit_device(db)
    assert device == "auto" and "torch sees no CUDA device now" in why
    monkeypatch.setattr(torch.cuda, "is_available", lambda: True)
    assert resolve_auto_fit_device(db)[0] == "cuda:0"
    assert resolve_auto_fit_device(db, host="another-machine")[0] == "cuda:0"
    assert socket.gethostname() != "another-machine"


def test_the_resolved_device_is_in_the_key_and_the_log(db, monkeypatch):
    said = []
    ctx = StageContext(store=None, db=db, log=said.append)
    cfg = FitMapConfig(steps=10).fit_config()
    assert resolve_fit_device(ctx, cfg) is cfg and said == []  # no bench: unchanged, silent
    auto_key = fit_key_settings(cfg)
    assert auto_key == {"fit": auto_key["fit"]} and auto_key["fit"]["device"] == "auto"
    _bench(db, 12.97, 1.44)
    monkeypatch.setattr(torch.cuda, "is_available", lambda: True)
    chosen = resolve_fit_device(ctx, cfg)
    assert chosen.device == "cuda:0" and said and said[0].startswith("fit-map: auto: cuda:0")
    key = fit_key_settings(chosen)
    assert key["fit"]["device"] == "cuda:0" and key["device_path"] == 2
    explicit = FitMapConfig(steps=10, fit={"device": "cpu"}).fit_config()
    assert resolve_fit_device(ctx, explicit) is explicit  # only "auto" is resolved
