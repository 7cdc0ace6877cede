"""The export says where its numbers come from: the config hash and how to recompute it,
the plan seed and planner version, the software version and git commit, the prompt
catalogue versions; each key described in the codebook."""

from __future__ import annotations

import csv
import hashlib
import json
import subprocess
from pathlib import Path

from sqlalchemy.orm import Session as DbSession

from chameleons import __version__
from chameleons.backend.export.provenance import PACKAGE_DIR, PROVENANCE_CODEBOOK
from chameleons.backend.export.service import ExportRequest, export_to_directory
from chameleons.backend.models import Study
from chameleons.experiment.design import PLANNER_VERSION
from chameleons.experiment.study import canonical_json
from chameleons.prompts.locations import REPOSITORY_PROMPTS
from tests.support.factories import populate


def test_metadata_carries_the_provenance(db_session: DbSession, tmp_path: Path) -> None:
    data = populate(db_session, 3)
    study = db_session.get(Study, data.study_id)
    assert study is not None
    study.plan_seed = 4242
    db_session.commit()
    out = tmp_path / "export"
    export_to_directory(db_session, ExportRequest(prompts_dir=REPOSITORY_PROMPTS), out)
    metadata = json.loads((out / "metadata.json").read_text("utf-8"))

    config = json.loads((out / "study_config.json").read_text("utf-8"))
    recipe = hashlib.sha256(canonical_json(config).encode("utf-8")).hexdigest()
    assert recipe == metadata["study_config_hash"] == data.spec.content_hash
    assert "sort_keys=True" in metadata["study_config_hash_recipe"]
    assert metadata["plan_seed"] == 4242
    assert metadata["planner_version"] == PLANNER_VERSION
    assert metadata["software_version"] == __version__
    head = subprocess.run(
        ["git", "-C", str(PACKAGE_DIR), "rev-parse", "HEAD"],
        capture_output=True, text=True, check=False,
    ).stdout.strip()  # fmt: skip
    if head:  # a git checkout (CI, developers): the exact commit
        assert metadata["software_commit"].startswith(head)
    actors = {actor.id for actor in data.spec.actors}
    assert set(metadata["prompt_catalogues"]) == actors
    versions = [v for v in metadata["prompt_catalogues"].values() if v is not None]
    assert versions, "the repository's demo catalogue has a version"
    assert all(len(v) == 16 for v in versions)
    # The Swedish catalogues a Swedish session played, versioned too (and not the English).
    swedish = metadata["prompt_catalogues_by_language"]["sv"]
    assert set(swedish) == actors
    assert all(swedish[a] is not None and swedish[a] != metadata["prompt_catalogues"][a]
               for a in actors)  # fmt: skip
    assert "en" not in metadata["prompt_catalogues_by_language"]

    with (out / "codebook.csv").open(newline="", encoding="utf-8") as handle:
        book = [r for r in csv.DictReader(handle) if r["table"] == "metadata.json"]
    assert {r["column"] for r in book} == {key for key, _, _ in PROVENANCE_CODEBOOK}
    assert set(metadata) >= {r["column"] for r in book}
    assert "Provenance" in (out / "README.md").read_text("utf-8")


def test_a_changed_catalogue_has_another_version(tmp_path: Path) -> None:
    from chameleons.backend.export.provenance import catalogue_version

    actor = tmp_path / "nova"
    actor.mkdir()
    assert catalogue_version(actor) is None
    (actor / "manifest.csv").write_text("id,text\np1,Hello\n", encoding="utf-8")
    first = catalogue_version(actor)
    (actor / "manifest.csv").write_text("id,text\np1,Hello!\n", encoding="utf-8")
    second = catalogue_version(actor)
    (actor / "audio").mkdir()
    (actor / "audio" / "p1.wav").write_bytes(b"RIFF")
    third = catalogue_version(actor)
    assert len({first, second, third}) == 3
