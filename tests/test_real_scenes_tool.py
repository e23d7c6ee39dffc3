"""tools/real_scenes.py's copying of scenes from git mirrors (issue 32), without Blender: a scene whose .blend reads
other files by relative path (FOLDERS, e.g. the Classroom) is copied with its folder's layout, and what the mirror
holds only as a Git LFS pointer, or not at all, is named and not written (a pointer cached as a .blend would make
Blender fail without saying why)."""
from __future__ import annotations

import importlib.util
import os
import subprocess

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


@pytest.fixture(scope="module")
def tool():
    """tools/real_scenes.py as a module."""
    spec = importlib.util.spec_from_file_location("real_scenes", os.path.join(ROOT, "tools", "real_scenes.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


POINTER = (b"version https://git-lfs.github.com/spec/v1\n"
           b"oid sha256:5c526ea3f280566e80253673c9955640527cd0f247ea41b1742620b5bc39f7a4\nsize 32045332\n")


def test_a_git_lfs_pointer_is_recognised_by_its_spec_line_and_names_its_oid_and_size(tool):
    assert tool.lfs_pointer(POINTER) == ("5c526ea3f280566e80253673c9955640527cd0f247ea41b1742620b5bc39f7a4", 32045332)
    assert tool.lfs_pointer(b"BLENDER-v279REND" + bytes(200)) is None      # a .blend's header
    assert tool.lfs_pointer(b"") is None
    assert tool.lfs_pointer(POINTER + b"x" * 2000) is None                   # pointers are small; this is content


def git(repo, *args):
    """Run git in `repo` and return its stdout."""
    return subprocess.run(["git", "-C", str(repo), *args], check=True, capture_output=True, text=True).stdout.strip()


def test_a_folder_scene_keeps_its_layout_and_skips_lfs_pointers_and_absent_files(tool, tmp_path, monkeypatch):
    repo = tmp_path / "mirror"
    files = {"room/room.blend": POINTER, "room/libs/chair.blend": b"BLENDER-v279" + bytes(64),
             "room/textures/wood.png": b"\x89PNG wood", "room/textures/glass.jpg": b"\xff\xd8 glass",
             "other/elsewhere.txt": b"not the scene's"}
    for path, data in files.items():
        (repo / path).parent.mkdir(parents=True, exist_ok=True)
        (repo / path).write_bytes(data)
    git(tmp_path, "init", "-q", str(repo))
    git(repo, "add", ".")
    git(repo, "-c", "user.name=t", "-c", "user.email=t@t", "commit", "-q", "-m", "scene")
    commit = git(repo, "rev-parse", "HEAD")
    blob = git(repo, "rev-parse", "HEAD:room/textures/glass.jpg")          # a snapshot without this file's content
    os.remove(repo / ".git" / "objects" / blob[:2] / blob[2:])
    cache = tmp_path / "cache"
    monkeypatch.setattr(tool, "CACHE", str(cache))
    monkeypatch.setitem(tool.FOLDERS, "room", ("someone/room", commit, "CC0", "room", "room.blend", "a room"))

    got = tool.fetch_folder("room", [str(repo / ".git")])

    assert sorted(got["copied"]) == ["libs/chair.blend", "textures/wood.png"]
    assert got["lfs"] == {"room.blend": 32045332}
    assert got["absent"] == ["textures/glass.jpg"]
    assert (cache / "room" / "libs" / "chair.blend").read_bytes() == files["room/libs/chair.blend"]
    assert (cache / "room" / "textures" / "wood.png").read_bytes() == files["room/textures/wood.png"]
    assert not (cache / "room" / "room.blend").exists() and not (cache / "room" / "textures" / "glass.jpg").exists()
    assert not (cache / "room" / "elsewhere.txt").exists()


def test_rigging_refuses_a_cached_lfs_pointer_before_starting_blender(tool, tmp_path, monkeypatch):
    (tmp_path / "room").mkdir()
    (tmp_path / "room" / "room.blend").write_bytes(POINTER)
    monkeypatch.setattr(tool, "CACHE", str(tmp_path))
    monkeypatch.setitem(tool.FOLDERS, "room", ("someone/room", "0" * 40, "CC0", "room", "room.blend", "a room"))
    monkeypatch.setattr(tool, "run", lambda *a, **k: pytest.fail("Blender was started on a Git LFS pointer"))

    assert tool.rig("room", "direct", 16, 12) == ("", ["room is a Git LFS pointer"])


def test_the_classroom_names_its_source_commit_and_licence(tool):
    repo, commit, licence, folder, blend, _ = tool.FOLDERS["classroom"]
    assert (repo, folder, blend) == ("Start-Ten/Virtual-Reality", "classroom", "classroom.blend")
    assert len(commit) == 40 and "CC0" in licence and "Christophe Seux" in licence
