"""Issue 33, item 3: ``rcb certify --scheduler`` runs the scenarios on a Dask cluster.

A real ``distributed.LocalCluster`` on 127.0.0.1 (two worker processes, as two hosts' workers
would be): the certificate is the one of local workers, bit for bit (its digest), with faults
and a domain error in a scenario; the CLI's answer is the same JSON as ``--jobs 1``; a
scheduler that does not answer, or ``--jobs`` beside ``--scheduler``, is a one-line error.
"""

from __future__ import annotations

import json
import socket
from pathlib import Path

import pytest
from typer.testing import CliRunner

from api.cli import cluster
from api.cli.cluster import cluster_executor
from api.cli.main import app
from supervisor.errors import InfeasibleError
from supervisor.inputs.plan import load_plan
from supervisor.virtual import scenario
from supervisor.virtual.certificate import digest
from supervisor.virtual.certify import simulate
from supervisor.virtual.fault_spec import parse_faults

distributed = pytest.importorskip("distributed", reason="the cluster extra is not installed")

ROOT = Path(__file__).resolve().parents[2]
DEMO_PLAN = ROOT / "examples" / "ivester_demo_part.toml"


@pytest.fixture(scope="module")
def scheduler():
    """A Dask scheduler and two single-threaded worker processes on 127.0.0.1."""
    with distributed.LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=True,
        host="127.0.0.1",
        dashboard_address=None,
    ) as local:
        yield local.scheduler_address


def test_the_cluster_certificate_is_the_local_one(scheduler):
    plan = load_plan(DEMO_PLAN)
    faults = parse_faults(["dropout:0.2", "step:3:1.12"])
    args = {"scenarios": 5, "parts": 5, "seed": 11, "faults": faults}
    local = simulate(plan, ["learn", "ivester"], jobs=1, **args)
    with cluster_executor(scheduler) as (executor, threads):
        assert threads == 2
        seen: list[int] = []
        remote = simulate(
            plan,
            ["learn", "ivester"],
            jobs=threads,
            executor=executor,
            progress=seen.append,
            **args,
        )
    assert digest(remote) == digest(local)
    assert [s.seed for s in remote[0].scenarios] == [11, 12, 13, 14, 15]
    assert seen == list(range(1, 11))  # every scenario of both strategies, in order


def test_a_domain_error_on_the_cluster_reaches_the_caller_as_itself(scheduler, monkeypatch):
    real = scenario.sample_machine

    def sample_machine(plan, seed, **kwargs):
        if seed == 1:
            raise InfeasibleError("rough-od", (), ())
        return real(plan, seed, **kwargs)

    # the workers run the real code (they never see this patch): the caller re-runs the
    # scenario its worker could not send back, here, and raises what it raised
    monkeypatch.setattr(scenario, "sample_machine", sample_machine)
    with cluster_executor(scheduler) as (executor, threads):
        with pytest.raises(InfeasibleError, match="rough-od"):
            simulate(
                load_plan(DEMO_PLAN),
                ["ivester"],
                scenarios=2,
                parts=1,
                jobs=threads,
                executor=_Failing(executor, seed=1),
            )


class _Failing:
    """An executor whose scenario of ``seed`` comes back as a worker's domain error (None)."""

    def __init__(self, executor, seed):
        self.executor, self.seed = executor, seed

    def map(self, fn, tasks):
        for task, traces in zip(tasks, self.executor.map(fn, tasks), strict=True):
            seeds = task[1]
            yield [None if s == self.seed else t for s, t in zip(seeds, traces, strict=True)]


def _invoke(args):
    return CliRunner().invoke(app, ["certify", str(DEMO_PLAN), *map(str, args)])


def test_the_cli_on_a_scheduler_answers_as_one_process(scheduler):
    common = ["--scenarios", 4, "--parts", 3, "--json", "--fault", "dropout:0.1"]
    remote = _invoke([*common, "--scheduler", scheduler])
    assert remote.exit_code == 0, remote.stderr
    local = _invoke([*common, "--jobs", 1])
    assert json.loads(remote.stdout) == json.loads(local.stdout)


def test_no_scheduler_there_is_a_one_line_error(monkeypatch):
    with socket.socket() as probe:  # a port nothing listens on
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    monkeypatch.setattr(cluster, "CONNECT_TIMEOUT_S", 2)
    result = _invoke(["--scenarios", 1, "--scheduler", f"tcp://127.0.0.1:{port}"])
    _one_line_error(result, ["--scheduler", str(port), "no Dask scheduler answers there"])


def test_jobs_beside_a_scheduler_is_refused_naming_jobs(scheduler):
    result = _invoke(["--scenarios", 1, "--jobs", 2, "--scheduler", scheduler])
    _one_line_error(result, ["--jobs", "not with --scheduler"])


def _one_line_error(result, needles):
    assert result.exit_code == 2, (result.exit_code, result.stdout, result.stderr)
    line = result.stderr.removesuffix("\n")
    assert "\n" not in line and "Traceback" not in line, result.stderr
    for needle in needles:
        assert needle in line, (needle, line)
