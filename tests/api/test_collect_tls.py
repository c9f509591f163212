"""``rcb collect`` over https to an agent and a service whose certificates a plant's own CA signed.

A review: the collector trusted only the public bundle (or what ``SSL_CERT_FILE`` names for the
whole process), and a certificate it did not trust was logged as a bare ``ConnectError``. Now
``[service] ca_file`` and ``[mtconnect] ca_file`` name the CA to trust for each address
(:mod:`api.collect.tls`), and an untrusted certificate is said so with the field that fixes
it. Real processes: ``rcb serve`` behind a TLS front, the test agent over TLS, ``rcb collect``;
the certificates are made at test time (:mod:`tls_support`).
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from tls_support import Pki, TlsFront, make_pki

from api.collect.config import config_from_mapping
from api.virtual_serve.mtconnect_agent import Agent, observations, serve
from models.errors import InputError
from supervisor.virtual.trace import block_map

from collect_support import Collector, demo_trace, new_plan, refused, service_parts, write_config


@pytest.fixture(scope="module")
def plant(tmp_path_factory) -> tuple[Pki, Pki]:
    """The plant's CA (its servers' certificates), and another CA no server here uses."""
    folder = tmp_path_factory.mktemp("pki")
    return make_pki(folder, "plant"), make_pki(folder, "other")


def _tls_agent(trace: Any, pki: Pki) -> tuple[Agent, Any, str]:
    """The test agent, its server wrapped in TLS before any client connects: https URL."""
    agent = Agent(observations(trace), buffer_size=100_000)
    server, url = serve(agent)
    server.socket = pki.server_context().wrap_socket(server.socket, server_side=True)
    return agent, server, url.replace("http://", "https://")


@pytest.fixture
def no_cert_variables() -> Iterator[None]:
    """The collector's environment without ``SSL_CERT_FILE``/``SSL_CERT_DIR``: only the file."""
    saved = {k: os.environ.pop(k) for k in ("SSL_CERT_FILE", "SSL_CERT_DIR") if k in os.environ}
    yield
    os.environ.update(saved)


def _config(folder: Path, url: str, plan_id: int, ops: Any, agent_url: str, **ca: str) -> Path:
    """collector.toml to the service at ``url`` with each ``ca`` (``service``, ``mtconnect``)
    a ``ca_file`` line."""
    source = f'[mtconnect]\nurl = "{agent_url}"\ncount = 400\npoll_s = 0.02'
    if "mtconnect" in ca:
        source += f'\nca_file = "{ca["mtconnect"]}"'
    config = write_config(folder, url, plan_id, block_map(ops), source)
    if "service" in ca:  # [service] is the file's second table: its line goes after its url
        text = config.read_text(encoding="utf-8")
        line = f'url = "{url}"\n'
        config.write_text(text.replace(line, f'{line}ca_file = "{ca["service"]}"\n'), "utf-8")
    return config


def test_parts_reach_the_service_over_https_with_the_plant_ca(
    sqlite_server, tmp_path, plant, no_cert_variables
) -> None:
    pki, _ = plant
    plan_id, setpoints = new_plan(sqlite_server)
    ops, trace = demo_trace(setpoints, parts=2)
    agent, server, agent_url = _tls_agent(trace, pki)
    front = TlsFront(pki, sqlite_server.port)
    (tmp_path / "ca.pem").write_bytes(pki.ca.read_bytes())  # relative to collector.toml
    service = f"https://127.0.0.1:{front.port}/api/v1"
    config = _config(
        tmp_path, service, plan_id, ops, agent_url, service="ca.pem", mtconnect="ca.pem"
    )
    collector = Collector(config, sqlite_server.keys["mes"])
    collector.start()
    try:
        agent.play(per_second=4000)
        collector.wait(lambda c: c.get("sent", 0) == 2, what="2 parts sent over https")
    finally:
        collector.stop()
        agent.stop()
        server.shutdown()
        front.close()
    assert sorted(service_parts(sqlite_server, plan_id)) == ["lathe-1/O1001/1", "lathe-1/O1001/2"]
    assert "not trusted" not in collector.log.read_text()


def test_a_certificate_not_trusted_is_said_so_with_the_field_that_fixes_it(
    sqlite_server, tmp_path, plant, no_cert_variables
) -> None:
    """The agent's certificate against another CA; then the service's against the public
    bundle (no ``service.ca_file``): each logged with its field, and no part is stored."""
    pki, other = plant
    plan_id, setpoints = new_plan(sqlite_server)
    ops, trace = demo_trace(setpoints, parts=1)
    agent, server, agent_url = _tls_agent(trace, pki)
    front = TlsFront(pki, sqlite_server.port)
    service = f"https://127.0.0.1:{front.port}/api/v1"
    try:
        wrong = tmp_path / "wrong"
        wrong.mkdir()
        config = _config(wrong, service, plan_id, ops, agent_url, mtconnect=str(other.ca))
        collector = Collector(config, sqlite_server.keys["mes"])
        collector.start(ready=False)
        try:
            collector.wait_log("mtconnect.ca_file names the CA file to trust", 1)
        finally:
            collector.stop()
        said = collector.log.read_text()
        assert "agent's device model not read (ConnectError: its certificate is not trusted" in said
        unset = tmp_path / "unset"
        unset.mkdir()
        config = _config(unset, service, plan_id, ops, agent_url, mtconnect=str(pki.ca))
        collector = Collector(config, sqlite_server.keys["mes"])
        collector.start()
        try:
            agent.play(per_second=4000)
            collector.wait_log("service.ca_file names the CA file to trust", 1)
            assert collector.counts().get("sent", 0) == 0
        finally:
            collector.stop()
    finally:
        agent.stop()
        server.shutdown()
        front.close()
    said = collector.log.read_text()
    assert "part 1: service not reached (ConnectError: its certificate is not trusted" in said
    assert service_parts(sqlite_server, plan_id) == []


GOOD: dict[str, Any] = {
    "collector": {"machine": "m"},
    "service": {"url": "https://127.0.0.1:1/api/v1", "plan": 1, "setpoint_version": 1},
    "signal": {"uncertainty": 0.02, "operations": ["a=N1:N2"]},
    "mtconnect": {"url": "https://127.0.0.1:2/dev"},
}


@pytest.mark.parametrize("section", ["service", "mtconnect"])
def test_a_ca_file_that_cannot_serve_is_refused_naming_it(section, tmp_path, plant) -> None:
    pki, _ = plant
    (tmp_path / "empty.pem").write_text("-----BEGIN NOTHING-----\n", encoding="utf-8")
    for value, why in (
        ("missing.pem", f"no such file ({tmp_path / 'missing.pem'})"),
        ("empty.pem", "holds no PEM certificate of a CA"),
        (str(pki.key), "holds no PEM certificate of a CA"),  # a key, not a certificate
    ):
        data = {k: dict(v) for k, v in GOOD.items()}
        data[section]["ca_file"] = value
        with pytest.raises(InputError) as caught:
            config_from_mapping(data, tmp_path)
        assert (caught.value.field, caught.value.value) == (f"{section}.ca_file", value)
        assert why in str(caught.value)
    data = {k: dict(v) for k, v in GOOD.items()}
    data[section] = {**data[section], "url": data[section]["url"].replace("https", "http")}
    data[section]["ca_file"] = str(pki.ca)
    with pytest.raises(InputError, match="trusts a CA for https only"):
        config_from_mapping(data, tmp_path)
    data[section]["url"] = GOOD[section]["url"]
    checked = config_from_mapping(data, tmp_path)
    given = checked.service_ca_file if section == "service" else checked.mtconnect.ca_file  # type: ignore[union-attr]
    assert given == pki.ca


def test_rcb_collect_refuses_a_missing_ca_file_at_start(tmp_path) -> None:
    source = '[mtconnect]\nurl = "https://127.0.0.1:2/lathe"\nca_file = "plant-ca.pem"'
    errors, stderr = refused(tmp_path, source)
    assert errors == [
        f"rcb: error: mtconnect.ca_file = 'plant-ca.pem': no such file "
        f"({tmp_path / 'plant-ca.pem'})"
    ], stderr
