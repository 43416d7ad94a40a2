"""phri_common.ros_domain: which ROS domain an in-process run uses."""

from __future__ import annotations

import pytest

from phri_common.ros_domain import run_domain


def test_unset_environment_gives_a_private_localhost_domain() -> None:
    domain, env, why = run_domain(None, {}, pid=4242)
    assert domain == 43  # 1 + 4242 mod 100
    assert env == {"ROS_DOMAIN_ID": "43", "ROS_AUTOMATIC_DISCOVERY_RANGE": "LOCALHOST"}
    assert "private" in why


def test_private_domains_differ_between_processes_and_are_never_zero() -> None:
    domains = {run_domain(None, {}, pid=p)[0] for p in range(1000, 1100)}
    assert len(domains) == 100 and 0 not in domains


def test_a_domain_the_user_set_is_kept_and_discovery_left_alone() -> None:
    domain, env, why = run_domain(None, {"ROS_DOMAIN_ID": " 7 "}, pid=1)
    assert (domain, env) == (7, {"ROS_DOMAIN_ID": "7"})
    assert "shared" in why


def test_the_option_wins_over_the_environment() -> None:
    assert run_domain(12, {"ROS_DOMAIN_ID": "7"})[0] == 12


@pytest.mark.parametrize(("requested", "environ", "named"), [
    (233, {}, "--ros-domain-id=233"),
    (-1, {}, "--ros-domain-id=-1"),
    (None, {"ROS_DOMAIN_ID": "500"}, "ROS_DOMAIN_ID=500"),
    (None, {"ROS_DOMAIN_ID": "zero"}, "ROS_DOMAIN_ID='zero'"),
])
def test_bad_ids_are_refused_naming_the_source_and_range(
        requested: int | None, environ: dict[str, str], named: str) -> None:
    with pytest.raises(ValueError, match=f"{named}.*0…232"):
        run_domain(requested, environ)
