"""Marked clip paths: the server names files relative to the prompts folder or the data
directory, and a worker resolves them against its own install."""

from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from chameleons.prompts.locations import (
    REPOSITORY_PROMPTS,
    marked_path,
    resolve_marked_path,
)
from chameleons.worker.behaviours import BehaviourError, create_behaviour
from chameleons.worker.behaviours.router import build_context
from chameleons.worker.frames import N_BLENDSHAPES

DEMO = "_natural/demo-natural.npz"


def install(root: Path, prompts: bool = True) -> SimpleNamespace:
    """A machine's folders, as the worker's config names them."""
    data_dir = root / "data"
    data_dir.mkdir(parents=True)
    return SimpleNamespace(data_dir=data_dir, prompts_dir=root / "prompts" if prompts else None)


def write_clip(path: Path, seconds: float) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    times = np.linspace(0.0, seconds, int(seconds * 30) + 1)
    np.savez(path, times=times, blendshapes=np.zeros((len(times), N_BLENDSHAPES)))


def test_a_prompts_path_resolves_in_this_machines_prompts_folder(tmp_path: Path) -> None:
    booth = install(tmp_path / "booth")
    write_clip(booth.prompts_dir / DEMO, 3.0)
    assert resolve_marked_path(f"prompts:{DEMO}", booth) == booth.prompts_dir / DEMO


def test_a_prompts_path_missing_locally_falls_back_to_the_shipped_one(tmp_path: Path) -> None:
    booth = install(tmp_path / "booth")  # a prompts folder without the demo clip
    resolved = resolve_marked_path(f"prompts:{DEMO}", booth)
    assert resolved == REPOSITORY_PROMPTS / DEMO
    assert resolved.is_file()


def test_a_data_path_resolves_in_this_machines_data_dir(tmp_path: Path) -> None:
    booth = install(tmp_path / "booth")
    relative = "recordings/study-1/session-1/participant.parquet"
    assert resolve_marked_path(f"data:{relative}", booth) == booth.data_dir / relative


def test_an_unmarked_path_is_used_as_it_is(tmp_path: Path) -> None:
    booth = install(tmp_path / "booth")
    assert resolve_marked_path(str(tmp_path / "clip.npz"), booth) == tmp_path / "clip.npz"


def test_the_server_marks_what_lies_in_its_folders_and_leaves_the_rest_absolute(
    tmp_path: Path,
) -> None:
    server = install(tmp_path / "server", prompts=False)
    recording = server.data_dir / "recordings" / "study-1" / "a.parquet"
    assert marked_path(recording, server) == "data:recordings/study-1/a.parquet"
    assert marked_path(REPOSITORY_PROMPTS / DEMO, server) == f"prompts:{DEMO}"
    elsewhere = tmp_path / "elsewhere" / "clip.npz"
    assert marked_path(elsewhere, server) == str(elsewhere.resolve())


def test_natural_loads_a_marked_clip_from_the_workers_own_install(tmp_path: Path) -> None:
    server, booth = install(tmp_path / "server"), install(tmp_path / "booth")
    write_clip(server.prompts_dir / DEMO, 2.0)
    write_clip(booth.prompts_dir / DEMO, 5.0)  # the booth's own copy: told apart by length
    write_clip(booth.data_dir / "recordings" / "yoked.npz", 7.0)
    context = build_context(locations=booth)
    demo = create_behaviour("natural", {"path": f"prompts:{DEMO}"}, context)
    assert demo.describe()["duration"] == pytest.approx(5.0)
    assert demo.describe()["source"] == f"prompts:{DEMO}"  # as the server sent it
    yoked = create_behaviour("natural", {"path": "data:recordings/yoked.npz"}, context)
    assert yoked.describe()["duration"] == pytest.approx(7.0)
    with pytest.raises(BehaviourError, match="not found"):
        create_behaviour("natural", {"path": "data:recordings/missing.npz"}, context)
