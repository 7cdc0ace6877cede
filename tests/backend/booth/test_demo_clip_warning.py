"""The shipped natural clip is synthetic (the face simulator's): the PI and the wizard are
warned before a real participant's robot replays it, and the record says what it was
(issue 28). A lab's own recorded clip raises no warning."""

from __future__ import annotations

import shutil
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
from fastapi.testclient import TestClient

from chameleons.backend.booth.behaviour import (
    SYNTHETIC_DEMO_CLIP,
    demo_clip_warning,
    describe_source,
    is_synthetic_demo,
)
from chameleons.experiment.study import load_default_study, load_study
from chameleons.settings import Settings
from tests.experiment.study_files import with_natural
from tests.support.bots import StaffApi, WizardBot, study_with_plan

PROMPTS = Path(__file__).resolve().parents[3] / "prompts"


def lab_prompts(root: Path) -> Path:
    """The demo prompts plus a clip the lab recorded (``_natural/lab-take.npz``)."""
    (root / "_natural").mkdir(parents=True)
    for actor in ("m1", "m2", "f1", "f2", "sv"):
        (root / actor).symlink_to(PROMPTS / actor, target_is_directory=True)
    with np.load(SYNTHETIC_DEMO_CLIP) as demo:
        recorded = {name: demo[name] for name in demo.files}
    recorded["head"] = recorded["head"] * 0.5  # other movement: not the synthetic clip
    np.savez_compressed(root / "_natural" / "lab-take.npz", **recorded)
    return root


@pytest.fixture
def settings(settings: Settings, tmp_path: Path) -> Settings:
    return settings.model_copy(update={"prompts_dir": lab_prompts(tmp_path / "prompts")})


def test_the_synthetic_clip_is_known_by_its_content(tmp_path: Path) -> None:
    copy = tmp_path / "our-clip.npz"
    shutil.copyfile(SYNTHETIC_DEMO_CLIP, copy)
    assert is_synthetic_demo(SYNTHETIC_DEMO_CLIP)
    assert is_synthetic_demo(copy)  # renamed, elsewhere: still the synthetic one
    lab = lab_prompts(tmp_path / "prompts") / "_natural" / "lab-take.npz"
    assert not is_synthetic_demo(lab)
    assert not is_synthetic_demo(tmp_path / "missing.npz")
    source = {"source": "clip", "clip": "demo-natural", "synthetic_demo": True}
    assert describe_source(source) == (
        "clip demo-natural (the synthetic demo clip, not a real conversation)"
    )


def test_the_default_study_is_warned_about_and_a_recorded_clip_is_not(tmp_path: Path) -> None:
    spec = load_default_study()
    demo = SimpleNamespace(settings=SimpleNamespace(prompts_dir=str(PROMPTS), data_dir=None))
    warning = demo_clip_warning(demo, spec)
    assert warning.startswith("Condition natural replays the synthetic demo clip demo-natural")
    assert "chameleons prompts import prompts/m1 TAKE --natural NAME" in warning
    assert demo_clip_warning(demo, spec, ["still", "copy"]) == ""
    lab = SimpleNamespace(settings=SimpleNamespace(
        prompts_dir=str(lab_prompts(tmp_path / "prompts")), data_dir=None))  # fmt: skip
    study_file = tmp_path / "study.yaml"
    study_file.write_text(with_natural(source="clip", clip="lab-take"), encoding="utf-8")
    assert demo_clip_warning(lab, load_study(study_file)) == ""
    yoked = tmp_path / "yoked.yaml"  # falls back to the clip until someone is recorded
    yoked.write_text(with_natural(source="yoked", clip="demo-natural"), encoding="utf-8")
    assert demo_clip_warning(lab, load_study(yoked)) != ""


def test_the_pi_and_the_wizard_see_it_before_any_session(client: TestClient, pi: StaffApi) -> None:
    demo_id = study_with_plan(pi, participants=2)
    assert "synthetic demo clip" in pi.get(f"/api/studies/{demo_id}")["natural_clip_warning"]
    assert 'class="error natural-clip-warning"' in client.get("/studies").text
    assert "Before a real participant" in client.get("/wizard").text
    recorded = study_with_plan(pi, participants=2, yaml=with_natural(source="clip",
                                                                    clip="lab-take"))  # fmt: skip
    assert pi.get(f"/api/studies/{recorded}")["natural_clip_warning"] == ""


def test_the_console_warns_before_the_robot_shows_it_to_a_real_participant(
    pi: StaffApi,
) -> None:
    study_id = study_with_plan(pi, participants=4)
    for rehearsal in (False, True):
        wizard = WizardBot.create(pi, study_id, rehearsal=rehearsal)
        console = f"/api/wizard/sessions/{wizard.session_id}"
        by_condition = {
            wizard.interaction(position)["condition"]: pi.get(
                f"{console}/prompts?position={position}"
            )["warnings"]
            for position in (1, 2, 3)
        }
        assert by_condition["still"] == by_condition["copy"] == []
        if rehearsal:
            assert by_condition["natural"] == []
        else:
            [warning] = by_condition["natural"]
            assert "replays the synthetic demo clip" in warning
