"""Named link profiles, the control API's validation and token, and `ptwl proxy` start-up rules."""

from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest

from latency.named import LinkConfigError, load_profiles, named_profile, named_profiles
from ptwl.launcher import ServiceProcess, running_proxy
from tests.command_line import run_ptwl


def test_named_profiles_load_and_cite_their_sources() -> None:
    profiles = named_profiles()
    assert {"zero", "earth_moon", "vozar_4s", "pryor_5s"} <= set(profiles)
    moon = profiles["earth_moon"]
    assert moon.uplink + moon.downlink == pytest.approx(2.56)
    assert moon.schedule is not None and moon.schedule.period == 86400.0  # the light time drifts daily
    assert [p.one_way_s for p in moon.schedule.delay][::2] == [1.28, 1.301, 1.28, 1.259, 1.28]
    assert profiles["vozar_4s"].uplink + profiles["vozar_4s"].downlink == pytest.approx(4.0)
    assert profiles["pryor_5s"].uplink + profiles["pryor_5s"].downlink == pytest.approx(5.0)
    assert all(p.description for p in profiles.values())
    with pytest.raises(LinkConfigError, match="unknown link profile 'mars'; valid: earth_moon"):
        named_profile("mars")


def test_a_bad_links_file_names_the_key(tmp_path: Path) -> None:
    path = tmp_path / "links.toml"
    path.write_text("[slow]\nuplink = -3\n")
    with pytest.raises(LinkConfigError, match=r"\[slow\] uplink: Input should be greater than or equal to 0"):
        load_profiles(path)


@pytest.fixture(scope="module")
def proxy(server: ServiceProcess) -> Iterator[ServiceProcess]:
    with running_proxy(server.url, "--profile", "earth_moon") as p:
        yield p


def test_put_takes_partial_updates_and_versions_them(proxy: ServiceProcess) -> None:
    before = httpx.get(proxy.url + "/_link/profile").json()
    assert before["uplink"] == 1.28 and before["jitter"]["distribution"] == "normal"
    after = httpx.put(proxy.url + "/_link/profile", json={"uplink": 0.1}).json()
    assert after["uplink"] == 0.1 and after["downlink"] == 1.28  # untouched fields stay
    assert after["version"] == before["version"] + 1


@pytest.mark.parametrize(
    ("body", "fragment"),
    [
        ('{"uplink": -1}', "uplink: Input should be greater than or equal to 0"),
        ('{"downlink": NaN}', "downlink"),
        ('{"loss": {"model": "bernoulli", "probability": 2}}', "loss.probability"),
        ('{"jitter": {"distribution": "cauchy"}}', "jitter.distribution"),
        ('{"uplink": ', "malformed JSON"),
        ("[1, 2]", "body must be a JSON object"),
        ('{"uplnk": 1}', "uplnk: Extra inputs are not permitted"),
    ],
)
def test_bad_profile_updates_are_refused_and_change_nothing(
    proxy: ServiceProcess, body: str, fragment: str
) -> None:
    before = httpx.get(proxy.url + "/_link/profile").json()
    response = httpx.put(
        proxy.url + "/_link/profile", content=body, headers={"content-type": "application/json"}
    )
    assert response.status_code == 422
    assert fragment in response.json()["detail"]
    assert httpx.get(proxy.url + "/_link/profile").json() == before


LINK_TOKEN = "link-token-0123456789"


def test_control_api_token(server: ServiceProcess) -> None:
    with running_proxy(server.url, "--token", LINK_TOKEN) as guarded:
        assert httpx.get(guarded.url + "/_link/stats").status_code == 401
        assert (
            httpx.get(guarded.url + "/_link/stats", headers={"Authorization": "Bearer no"}).status_code == 403
        )
        ok = httpx.get(guarded.url + "/_link/stats", headers={"Authorization": f"Bearer {LINK_TOKEN}"})
        assert ok.status_code == 200 and {"uplink", "downlink"} <= set(ok.json())
        # The schedule's outlook (issue 32) is behind the same door, Host and Origin too.
        assert httpx.get(guarded.url + "/_link/outlook").status_code == 401
        bearer = {"Authorization": f"Bearer {LINK_TOKEN}"}
        outlook = httpx.get(guarded.url + "/_link/outlook", headers=bearer)
        assert outlook.status_code == 200 and outlook.json()["downlink"]["in_contact"] is True
        foreign = {**bearer, "Origin": "http://evil.example"}
        assert httpx.get(guarded.url + "/_link/outlook", headers=foreign).status_code == 403
        assert (
            httpx.get(guarded.url + "/_link/outlook", headers={**bearer, "Host": "evil.example"}).status_code
            == 400
        )


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--host", "0.0.0.0"], "refusing to bind 0.0.0.0: a non-loopback address needs an access token"),
        (["--profile", "mars"], "unknown link profile 'mars'"),
    ],
)
@pytest.mark.parametrize("entry", ["ptwl.cli", "ptwl.proxy_cli"])  # `ptwl proxy`; what the launcher starts
def test_proxy_refuses_to_start(args: list[str], message: str, entry: str) -> None:
    result = run_ptwl("proxy", "--port", "0", *args, module=entry)
    assert result.returncode == 2
    assert message in result.stderr
