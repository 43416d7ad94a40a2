"""Static checks of docker/ (the image cannot be built on the development machines).

A small rule set in the spirit of hadolint: pinned base images, non-interactive apt with cleaned
lists, every workspace package copied into the image, colcon build and test, the Python
dependencies taken from requirements.txt, and compose services that point at existing stages.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest
import yaml

ROOT = Path(__file__).resolve().parents[2]
DOCKERFILE = ROOT / "docker" / "Dockerfile"
COMPOSE = ROOT / "docker" / "compose.yaml"


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
    for pkg in packages:
        if pkg not in copied:
            problems.append(f"package directory {pkg} is not COPYed into the image")
    joined = " ".join(a for k, a in ins if k == "RUN")
    if "colcon build" not in joined:
        problems.append("no colcon build")
    if "colcon test" not in joined or "colcon test-result" not in joined:
        problems.append("no colcon test / colcon test-result")
    if "requirements.txt" not in copied or "-r /tmp/requirements" not in joined:
        problems.append("Python dependencies do not come from requirements.txt")
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
    assert "colcon test" in " ".join(services["test"]["command"])


def test_dockerignore_keeps_host_builds_out() -> None:
    ignored = (ROOT / ".dockerignore").read_text(encoding="utf-8").split()
    for entry in (".venv", "build", "install", "log", ".git"):
        assert entry in ignored
