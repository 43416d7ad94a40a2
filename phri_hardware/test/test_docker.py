"""Static checks of docker/ (the image cannot be built on the development machines).

A small rule set in the spirit of hadolint (which passes the Dockerfile too, docker/README.md):
pinned base images, non-interactive apt with cleaned lists, apt versions pinned or the DL3008
exception stated, no unquoted command substitution, every workspace package copied into the
image, the dependencies installed the ROS way (rosdep install from the package manifests, the
pip keys allowed past PEP 668, then requirements-ros.txt), colcon build, the suite in the test
stage, and compose services that point at existing stages. requirements-ros.txt pins exact
versions within requirements.txt's ranges.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[2]
DOCKERFILE = ROOT / "docker" / "Dockerfile"
COMPOSE = ROOT / "docker" / "compose.yaml"
RUN_SUITE = ROOT / "docker" / "run_suite.sh"


def instructions(text: str) -> list[tuple[str, str]]:
    """(INSTRUCTION, arguments) with line continuations joined and comments dropped."""
    out: list[tuple[str, str]] = []
    buffer = ""
    for raw in text.splitlines():
        line = raw.strip()
        if not buffer and (not line or line.startswith("#")):
            continue
        if line.startswith("#"):
            continue
        if line.endswith("\\"):
            buffer += line[:-1] + " "
            continue
        buffer += line
        keyword, _, args = buffer.partition(" ")
        out.append((keyword.upper(), args.strip()))
        buffer = ""
    assert not buffer, "Dockerfile ends inside a line continuation"
    return out


def lint(text: str, packages: list[str]) -> list[str]:
    """Every rule violation in a Dockerfile's ``text`` (empty = clean)."""
    problems: list[str] = []
    ins = instructions(text)
    stages: set[str] = set()
    noninteractive = False
    copied: set[str] = set()
    for keyword, args in ins:
        if keyword == "FROM":
            m = re.match(r"(\S+)(?:\s+AS\s+(\S+))?$", args, re.IGNORECASE)
            if not m:
                problems.append(f"FROM {args}: cannot parse")
                continue
            image, stage = m.group(1), m.group(2)
            if image not in stages:
                _name, _, tag = image.rpartition(":") if ":" in image else (image, "", "")
                if "@sha256:" not in image and (not tag or "/" in tag):
                    problems.append(f"FROM {image}: base image without a tag")
                elif tag == "latest":
                    problems.append(f"FROM {image}: 'latest' is not a pinned tag")
                if not re.match(r"^ros:(kilted|jazzy)-", image):
                    problems.append(f"FROM {image}: not an official ROS 2 Kilted/Jazzy image")
            if stage:
                stages.add(stage)
        elif keyword in ("ENV", "ARG") and "DEBIAN_FRONTEND=noninteractive" in args:
            noninteractive = True
        elif keyword == "ADD":
            problems.append(f"ADD {args}: use COPY for local files")
        elif keyword == "COPY":
            parts = [p for p in args.split() if not p.startswith("--")]
            copied.update(p.rstrip("/") for p in parts[:-1])
        elif keyword == "RUN":
            if "sudo " in args:
                problems.append("RUN uses sudo")
            if "apt-get install" in args or "apt install" in args:
                if "apt install" in args:
                    problems.append("RUN uses 'apt' (use apt-get in scripts)")
                if not noninteractive:
                    problems.append("apt-get install before DEBIAN_FRONTEND=noninteractive")
                if not re.search(r"apt-get install\s+(-\S+\s+)*-y", args) and "-y" not in args:
                    problems.append("apt-get install without -y")
                if "--no-install-recommends" not in args:
                    problems.append("apt-get install without --no-install-recommends")
                if args.find("apt-get update") < 0 or args.find("apt-get update") > args.find(
                        "apt-get install"):
                    problems.append("apt-get install without apt-get update in the same RUN")
                if "rm -rf /var/lib/apt/lists/*" not in args:
                    problems.append("apt lists not cleaned in the RUN that installs")
            if "pip install" in args and "--no-cache-dir" not in args and (
                    "PIP_NO_CACHE_DIR=1" not in text):
                problems.append("pip install keeps its cache")
            if re.search(r"(^|[\s=(])\$\(", args):
                problems.append(f"RUN {args[:40]}…: unquoted command substitution (SC2046)")
    for pkg in packages:
        if pkg not in copied:
            problems.append(f"package directory {pkg} is not COPYed into the image")
    problems += apt_pin_problems(text) + ros_way_problems(text, ins, copied)
    return problems


def apt_pin_problems(text: str) -> list[str]:
    """DL3008: every ``apt-get install`` names ``pkg=version``, or its RUN is preceded by
    ``# hadolint ignore=DL3008`` with a comment saying why."""
    problems = []
    lines = text.splitlines()
    for i, line in enumerate(lines):
        if not line.startswith("RUN") or "apt-get install" not in text_of_run(lines, i):
            continue
        run = text_of_run(lines, i)
        packages = [w for w in run.split("apt-get install", 1)[1].split("&&")[0].split()
                    if not w.startswith("-") and w != "\\"]
        if all("=" in w for w in packages):
            continue
        comments = []
        for above in reversed(lines[:i]):
            if not above.startswith("#"):
                break
            comments.append(above)
        if not any("hadolint ignore=DL3008" in c for c in comments):
            problems.append(f"line {i + 1}: apt-get install without versions (DL3008)")
        elif len(comments) < 2:
            problems.append(f"line {i + 1}: DL3008 ignored without a reason")
    return problems


def text_of_run(lines: list[str], start: int) -> str:
    """The RUN instruction starting at ``lines[start]`` with its continuation lines."""
    out = []
    for line in lines[start:]:
        out.append(line.rstrip("\\").strip())
        if not line.rstrip().endswith("\\"):
            break
    return " ".join(out)


def ros_way_problems(text: str, ins: list[tuple[str, str]], copied: set[str]) -> list[str]:
    """The dependencies come the ROS way: ``rosdep install --from-paths … --ignore-src -y``
    after PIP_BREAK_SYSTEM_PACKAGES=1 (rosdep's -pip keys on Ubuntu 24.04), then the pinned
    requirements-ros.txt; colcon build; the test stage runs docker/run_suite.sh."""
    problems = []
    runs = [a for k, a in ins if k == "RUN"]
    rosdep = [a for a in runs if "rosdep install" in a]
    if not any("--from-paths" in a and "--ignore-src" in a and " -y" in a for a in rosdep):
        problems.append("no rosdep install --from-paths … --ignore-src -y")
    env = " ".join(a for k, a in ins if k == "ENV")
    if "PIP_BREAK_SYSTEM_PACKAGES=1" not in env:
        problems.append("rosdep's -pip keys fail on Ubuntu 24.04 without "
                        "PIP_BREAK_SYSTEM_PACKAGES=1")
    if "requirements-ros.txt" not in copied or not any(
            "-r /tmp/requirements-ros.txt" in a for a in runs):
        problems.append("the pinned ROS-path set (requirements-ros.txt) is not installed")
    if rosdep and runs.index(rosdep[0]) > min(
            (i for i, a in enumerate(runs) if "-r /tmp/requirements-ros.txt" in a), default=0):
        problems.append("requirements-ros.txt must come after rosdep (it pins over apt)")
    if not any("colcon build" in a for a in runs):
        problems.append("no colcon build")
    if "/phri_run_suite.sh" not in " ".join(runs):
        problems.append("the test stage does not run docker/run_suite.sh")
    return problems


def workspace_packages() -> list[str]:
    return sorted(p.parent.name for p in ROOT.glob("*/package.xml"))


def dockerfile_stages() -> set[str]:
    return {m.group(1) for m in re.finditer(r"^FROM\s+\S+\s+AS\s+(\S+)",
                                              DOCKERFILE.read_text(), re.MULTILINE | re.I)}


def test_the_dockerfile_passes_the_rules() -> None:
    packages = workspace_packages()
    assert "phri_hardware" in packages and len(packages) >= 8
    assert lint(DOCKERFILE.read_text(encoding="utf-8"), packages) == []


@pytest.mark.parametrize(("snippet", "expected"), [
    ("FROM ros:kilted-ros-base\nENV DEBIAN_FRONTEND=noninteractive\nRUN apt-get update && "
     "apt-get install -y --no-install-recommends git && rm -rf /var/lib/apt/lists/*\n",
     "DL3008"),
    ("FROM ros:kilted-ros-base\nENV DEBIAN_FRONTEND=noninteractive\n# hadolint ignore=DL3008\n"
     "RUN apt-get update && apt-get install -y --no-install-recommends git "
     "&& rm -rf /var/lib/apt/lists/*\n", "without a reason"),
    ("FROM ros:kilted-ros-base\nRUN echo $(ls)\n", "SC2046"),
    ("FROM ros:kilted-ros-base\nRUN rosdep install --from-paths src -y\n", "--ignore-src"),
    ("FROM ros:kilted-ros-base\nRUN rosdep install --from-paths src --ignore-src -y\n",
     "PIP_BREAK_SYSTEM_PACKAGES"),
    ("FROM ros:latest\n", "'latest'"),
    ("FROM ros\n", "without a tag"),
    ("FROM ubuntu:24.04\n", "not an official ROS 2"),
    ("FROM ros:kilted-ros-base\nRUN apt-get update && apt-get install -y --no-install-recommends"
     " git\n", "noninteractive"),
    ("FROM ros:kilted-ros-base\nENV DEBIAN_FRONTEND=noninteractive\nRUN apt-get update && "
     "apt-get install -y --no-install-recommends git\n", "apt lists not cleaned"),
    ("FROM ros:kilted-ros-base\nENV DEBIAN_FRONTEND=noninteractive\nRUN apt-get install -y "
     "--no-install-recommends git && rm -rf /var/lib/apt/lists/*\n", "apt-get update"),
    ("FROM ros:kilted-ros-base\nADD . /ws\n", "use COPY"),
])
def test_the_rules_catch_what_they_claim(snippet: str, expected: str) -> None:
    problems = lint(snippet, ["phri_common"])
    assert any(expected in p for p in problems), problems
    assert any("phri_common is not COPYed" in p for p in problems)


def test_the_test_stage_runs_the_whole_suite() -> None:
    """docker/run_suite.sh: what ./test.sh runs, on the image's colcon build, failing on any."""
    script = "\n".join(line for line in RUN_SUITE.read_text(encoding="utf-8").splitlines()
                       if not line.lstrip().startswith("#"))
    steps = ["ruff check .", "; mypy", "colcon test ", "colcon test-result",
             "colcon lint", "phri_common.junit_summary"]
    positions = [script.find(step) for step in steps]
    assert all(p >= 0 for p in positions) and positions == sorted(positions), positions
    assert "--return-code-on-test-failure" in script and 'exit "$status"' in script
    assert "--symlink-install" not in script  # the plain build the image installed


def _version(text: str) -> tuple[int, ...]:
    return tuple(int(part) for part in re.findall(r"\d+", text)[:3])


def _ranges(path: Path) -> dict[str, list[tuple[str, str]]]:
    """name → [(operator, version)] of a requirements file (lower-cased, - for _)."""
    out: dict[str, list[tuple[str, str]]] = {}
    for line in path.read_text(encoding="utf-8").splitlines():
        line = line.split("#")[0].strip()
        m = re.match(r"([A-Za-z0-9_.-]+)\s*(.*)", line)
        if m:
            out[m.group(1).lower().replace("_", "-")] = re.findall(
                r"(==|>=|<=|<|>)\s*([0-9][0-9.]*)", m.group(2))
    return out


def test_ros_path_set_is_pinned_within_requirements_txt() -> None:
    """requirements-ros.txt: exact versions (the set the suite ran on), each inside
    requirements.txt's range, covering every module without a rosdep key, the pip keys and the
    modules whose Ubuntu 24.04 apt version is below requirements.txt's minimum."""
    ops = {">=": lambda a, b: a >= b, "<": lambda a, b: a < b, "<=": lambda a, b: a <= b,
           ">": lambda a, b: a > b, "==": lambda a, b: a == b}
    ros = _ranges(ROOT / "requirements-ros.txt")
    pip_path = _ranges(ROOT / "requirements.txt")
    for name, spec in ros.items():
        assert len(spec) == 1 and spec[0][0] == "==", f"{name}: not an exact pin"
        pinned = _version(spec[0][1])
        for op, bound in pip_path.get(name, []):
            assert ops[op](pinned, _version(bound)), f"{name} {spec[0][1]} outside {op}{bound}"
    needed = {"daqp", "osqp", "ur-rtde", "foxglove-sdk", "imageio-ffmpeg",  # no rosdep key
              "mujoco", "rosbags", "mcap-ros2-support",  # rosdep's -pip keys
              "numpy", "scipy", "matplotlib", "numba", "websockets"}  # apt's too old / kept
    assert needed <= set(ros), needed - set(ros)


def test_compose_services_use_existing_stages() -> None:
    compose = yaml.safe_load(COMPOSE.read_text(encoding="utf-8"))
    services = compose["services"]
    assert {"sim", "rviz", "test"} <= set(services)
    stages = dockerfile_stages()
    for name, service in services.items():
        build = service["build"]
        assert build["dockerfile"] == "docker/Dockerfile", name
        assert (COMPOSE.parent / build["context"]).resolve() == ROOT, name
        assert build["target"] in stages, f"{name}: unknown target {build['target']}"
    assert "DISPLAY" in services["rviz"]["environment"]
    assert any("/tmp/.X11-unix" in v for v in services["rviz"]["volumes"])
    assert services["test"]["build"]["target"] == "test"
    assert services["test"]["command"] == ["/phri_run_suite.sh"]


def test_dockerignore_keeps_host_builds_out() -> None:
    ignored = (ROOT / ".dockerignore").read_text(encoding="utf-8").split()
    for entry in (".venv", "build", "install", "log", ".git"):
        assert entry in ignored
