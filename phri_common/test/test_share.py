"""Package data is found where ROS installs it (the ament index) before the source tree, and a
generated file is compared to its generator up to arithmetic noise."""

from __future__ import annotations

from pathlib import Path

import pytest

from phri_common.share import package_share, share_file, source_tree
from phri_common.testing import generated_text_differences


def _install_prefix(root: Path, package: str) -> Path:
    """A colcon-style install prefix holding ``package``'s index marker and share directory."""
    index = root / "share" / "ament_index" / "resource_index" / "packages"
    index.mkdir(parents=True)
    (index / package).write_text("")
    share = root / "share" / package
    (share / "urdf").mkdir(parents=True)
    (share / "urdf" / "robot.urdf").write_text("<robot/>")
    return share


def test_the_ament_index_comes_before_the_source_tree(tmp_path: Path,
                                                      monkeypatch: pytest.MonkeyPatch) -> None:
    # phri_common is importable from its source tree here (editable or PYTHONPATH) ...
    monkeypatch.delenv("AMENT_PREFIX_PATH", raising=False)
    source = package_share("phri_common")
    assert (source / "package.xml").is_file() and source == source_tree("phri_common")
    # ... but an installed copy indexed on AMENT_PREFIX_PATH is what ROS uses.
    share = _install_prefix(tmp_path / "install", "phri_common")
    empty = tmp_path / "other"
    empty.mkdir()
    monkeypatch.setenv("AMENT_PREFIX_PATH", f"{empty}:{tmp_path / 'install'}")
    assert package_share("phri_common") == share
    assert share_file("phri_common", "urdf/robot.urdf") == share / "urdf" / "robot.urdf"


def test_an_unindexed_share_directory_is_not_taken(tmp_path: Path,
                                                   monkeypatch: pytest.MonkeyPatch) -> None:
    share = _install_prefix(tmp_path, "phri_common")
    (tmp_path / "share" / "ament_index" / "resource_index" / "packages" / "phri_common").unlink()
    monkeypatch.setenv("AMENT_PREFIX_PATH", str(tmp_path))
    assert package_share("phri_common") != share


def test_missing_package_and_missing_file_name_what_was_looked_for(
        monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("AMENT_PREFIX_PATH", raising=False)
    with pytest.raises(FileNotFoundError, match="no_such_package: data files not found"):
        package_share("no_such_package")
    with pytest.raises(FileNotFoundError, match=r"phri_common: nothing/here.yaml is not"):
        share_file("phri_common", "nothing/here.yaml")


def test_generated_text_differs_only_beyond_arithmetic_noise() -> None:
    stored = '<origin xyz="9.97098729e-20 0 0.232245267"/>\n<mass value="150"/>'
    assert generated_text_differences(stored, stored.replace("9.97098729e-20", "0"), 1e-8) == []
    assert generated_text_differences(stored, stored.replace("0.232245267", "0.232245268"),
                                      1e-8) == []
    changed = generated_text_differences(stored, stored.replace("150", "151"), 1e-8)
    assert changed == ['line 2: <mass value="150"/> | <mass value="151"/>']
    renamed = generated_text_differences(stored, stored.replace("mass", "weight"), 1e-8)
    assert len(renamed) == 1 and renamed[0].startswith("line 2")
    assert generated_text_differences(stored, stored + "\n<extra/>", 1e-8) == \
        ["2 lines stored, 3 generated"]
    assert generated_text_differences("a 1 b", "a 1 2 b", 1e-8) == ["line 1: a 1 b | a 1 2 b"]
