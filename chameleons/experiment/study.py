"""Loading a study from YAML (or from a stored config snapshot), validated in full.

``load_study`` reads one YAML file; every problem is reported with its place, all at once
(``StudyError.problems``). The loaded :class:`~chameleons.experiment.model.Study` carries
``config``, a canonical JSON-able snapshot (keyed collections become lists of objects with
an ``id``, defaults filled in), and ``content_hash``, the sha256 of that snapshot's
canonical JSON. ``study_from_config(study.config)`` rebuilds an equal study with the same
hash, so a stored snapshot always identifies the study its data was collected under.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from dataclasses import asdict, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import yaml

from chameleons.experiment import languages, personas, sections
from chameleons.experiment.lines import line_of, node_lines
from chameleons.experiment.model import Study
from chameleons.experiment.procedure import procedure_config, read_procedure
from chameleons.experiment.reader import SLUG, Reader
from chameleons.experiment.suggestions import DEFAULT_RULE, RULES
from chameleons.experiment.wording import duplicate_wording
from chameleons.experiment.yaml_limits import ExpansionError, expanded_size

__all__ = [
    "Study",
    "StudyError",
    "canonical_json",
    "default_study_path",
    "load_default_study",
    "load_study",
    "study_from_config",
]

TOP_LEVEL_REQUIRED = ["id", "name", "conditions", "tasks", "item_sets", "actors", "faces"]
TOP_LEVEL_OPTIONAL = [
    "description",
    "suggestions_per_interaction",
    "suggestion_rule",
    "design",
    "robot_names",
    "personas",
    "questionnaires",
    "procedure",
    "languages",
    "default_language",
]
SUGGESTION_RULES = RULES  # the first is the default of a new study file
# A snapshot stored before the rule was a setting was collected under the up-only rule.
LEGACY_SUGGESTION_RULE = "up_only"


class StudyError(ValueError):
    """A study file or snapshot is unusable; ``problems`` lists every problem with its place
    (``place: message``), ``located`` the same as ``file:line: place: message`` where the
    line is known."""

    def __init__(
        self, problems: list[str], source: str = "study", lines: dict[str, int] | None = None
    ) -> None:
        self.problems = list(problems)
        self.source = source
        self.located = [_locate(p, source, lines or {}) for p in self.problems]
        listed = "\n".join(f"  - {p}" for p in self.located)
        super().__init__(f"{source} has {len(self.problems)} problem(s):\n{listed}")


def _locate(problem: str, source: str, lines: dict[str, int]) -> str:
    line = line_of(problem, lines)
    return problem if line is None else f"{source}:{line}: {problem}"


def default_study_path() -> Path:
    return Path(__file__).parent / "studies" / "default" / "study.yaml"


def load_default_study() -> Study:
    return load_study(default_study_path())


def load_study(path: Path | str, behaviours: sections.Behaviours | None = None) -> Study:
    """A study from its YAML file. ``behaviours`` (name -> declared parameters) defaults to
    the worker's behaviour registry, built-ins and installed plug-ins."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise StudyError([f"cannot read the file: {exc.strerror or exc}"], str(path)) from exc
    document, duplicates, root = _parse_yaml(text, str(path))
    lines = node_lines(root)  # from the same parse: the YAML is read once
    try:
        study = _build(document, str(path), duplicates, _registry(behaviours))
    except StudyError as exc:
        raise StudyError(exc.problems, exc.source, lines) from None
    located = tuple(_locate(warning, str(path), lines) for warning in study.warnings)
    return replace(study, warnings=located)


def study_from_config(config: dict[str, Any]) -> Study:
    """Rebuild a study from its stored snapshot (``Study.config``). A snapshot keeps the
    parameters it was stored with, even for a behaviour this machine does not have; one
    stored before a setting existed gets what the software did then."""
    return _build(config, "study config", [], _registry(None), snapshot=True)


def _registry(behaviours: sections.Behaviours | None) -> sections.Behaviours:
    if behaviours is not None:
        return behaviours
    from chameleons.worker.behaviours.registry import behaviour_parameters

    return behaviour_parameters()


def canonical_json(config: dict[str, Any]) -> str:
    """The exact text the content hash is computed over (sorted keys, no whitespace)."""
    return json.dumps(config, sort_keys=True, separators=(",", ":"), ensure_ascii=False)


# libyaml's parser (PyYAML's C extension) where it is installed: the same safe loader about
# twenty times faster than the pure-Python one (the default study took about 0.4 s to read,
# on every study created, every demo and in hundreds of tests). Not a ternary: type
# checkers subclass a plain alias only (the C loader's interface is the Python one's).
if TYPE_CHECKING or not yaml.__with_libyaml__:  # noqa: SIM108
    _SafeLoader = yaml.SafeLoader
else:
    _SafeLoader = yaml.CSafeLoader
NESTED_TOO_DEEPLY = "nested too deeply: a study needs a few levels, not hundreds"


class _DuplicateKeyLoader(_SafeLoader):
    """A safe loader that records duplicate mapping keys instead of silently keeping the last."""

    duplicates: list[str]


def _construct_mapping(loader: _DuplicateKeyLoader, node: yaml.MappingNode) -> dict[Any, Any]:
    seen: set[Any] = set()
    for key_node, _ in node.value:
        key = loader.construct_object(key_node)
        if key in seen:
            line = key_node.start_mark.line + 1
            loader.duplicates.append(f"line {line}: duplicate key {key!r}")
        seen.add(key)
    return loader.construct_mapping(node)


_DuplicateKeyLoader.add_constructor(
    yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG,
    _construct_mapping,
)


def _parse_yaml(text: str, source: str) -> tuple[Any, list[str], yaml.Node | None]:
    """The document, its duplicate keys and its composed root node (for line numbers)."""
    try:  # the reader refuses control characters as the loader is made, not when it reads
        loader = _DuplicateKeyLoader(text)
    except yaml.YAMLError as exc:
        raise StudyError([f"not valid YAML: {exc}"], source) from exc
    loader.duplicates = []
    try:
        node = loader.get_single_node()
        if node is None:
            return None, [], None
        expanded_size(node)  # before anything walks the aliases' repetitions (yaml_limits)
        document = loader.construct_document(node)
    except yaml.YAMLError as exc:
        if "maximum nesting depth" in str(exc):  # libyaml stops at 1,000 levels
            raise StudyError([NESTED_TOO_DEEPLY], source) from exc
        raise StudyError([f"not valid YAML: {exc}"], source) from exc
    except ExpansionError as exc:
        raise StudyError([f"too large: {exc}"], source) from exc
    except RecursionError as exc:  # PyYAML's Python parser composes nested collections recursively
        raise StudyError([NESTED_TOO_DEEPLY], source) from exc
    finally:
        loader.dispose()
    return document, loader.duplicates, node


def _build(
    document: object,
    source: str,
    duplicates: list[str],
    behaviours: sections.Behaviours,
    *,
    snapshot: bool = False,
) -> Study:
    reader = Reader()
    reader.problems.extend(duplicates)
    top = reader.mapping(document, "")
    if not isinstance(document, dict):
        raise StudyError(reader.problems, source)
    reader.check_keys(top, "", TOP_LEVEL_REQUIRED, TOP_LEVEL_OPTIONAL)
    declared, default = languages.read_languages(reader, top)
    languages.check(reader, top, declared)
    missing, incomplete = languages.catalogue_notes(top, declared)
    # A new study is refused; a stored one (data collected under it) is only warned about.
    reader.problems.extend([] if snapshot else missing)
    resolved = languages.resolve(top, default, default)
    parts, name_genders = _read_parts(reader, resolved, behaviours, snapshot)
    if reader.problems:
        raise StudyError(reader.problems, source)
    others = {
        language: _read_parts(
            Reader(), languages.resolve(top, language, default), behaviours, snapshot
        )[0]  # the same document with other texts: no new problems
        for language in declared
        if language != default
    }
    configs = {lang: _config_of(p, name_genders) for lang, p in {default: parts, **others}.items()}
    config = languages.merge(configs, tuple(configs))
    if "languages" in top:  # a study without them keeps the hash it had before
        config = {**config, "languages": list(declared), "default_language": default}
    digest = hashlib.sha256(canonical_json(config).encode("utf-8")).hexdigest()
    notes = (missing if snapshot else []) + incomplete
    warnings = (*notes, *duplicate_wording(parts["questionnaires"]))
    common = {
        "config": config,
        "content_hash": digest,
        "name_genders": name_genders,
        "languages": declared,
        "default_language": default,
    }
    localized = {lang: Study(**others[lang], **common) for lang in others}
    return Study(**parts, **common, warnings=warnings, localized=localized)


def _read_parts(
    reader: Reader, top: dict[str, Any], behaviours: sections.Behaviours, snapshot: bool
) -> tuple[dict[str, Any], dict[str, str]]:
    """Every section of one language's document (problems go to ``reader``)."""
    design = reader.mapping(top.get("design", {}), "design")
    reader.check_keys(design, "design", [], ["alternate_tasks"])
    tasks = sections.read_tasks(reader, top.get("tasks", {}))
    names, name_genders = sections.read_robot_names(reader, top.get("robot_names", []))
    parts: dict[str, Any] = {
        "id": reader.identifier(top.get("id", ""), "id", SLUG),
        "name": reader.text(top, "name", ""),
        "description": reader.text(top, "description", "", default="", allow_empty=True),
        "conditions": sections.read_conditions(
            reader, top.get("conditions", {}), behaviours, snapshot=snapshot
        ),
        "tasks": tasks,
        "item_sets": sections.read_item_sets(reader, top.get("item_sets", {}), tasks),
        "suggestions_per_interaction": reader.integer(
            top, "suggestions_per_interaction", "", default=3, minimum=0, maximum=20
        ),
        "suggestion_rule": _suggestion_rule(reader, top, snapshot),
        "alternate_tasks": reader.boolean(design, "alternate_tasks", "design", default=True),
        "actors": sections.read_actors(reader, top.get("actors", {})),
        "faces": sections.read_faces(reader, top.get("faces", {})),
        "robot_names": names,
        "personas": sections.read_personas(reader, top.get("personas"), snapshot=snapshot),
        "questionnaires": sections.read_questionnaires(reader, top.get("questionnaires", {})),
        "procedure": read_procedure(reader, top.get("procedure")),
    }
    _check_design_fits(reader, parts)
    if not reader.problems:
        personas.check_fits(reader, parts, name_genders)
    return parts, name_genders


def _suggestion_rule(reader: Reader, top: Mapping[str, Any], snapshot: bool) -> str:
    default = LEGACY_SUGGESTION_RULE if snapshot else DEFAULT_RULE
    rule = top.get("suggestion_rule", default)
    if rule not in SUGGESTION_RULES:
        reader.problem("suggestion_rule", f"must be one of {list(SUGGESTION_RULES)}, got {rule!r}")
        return default
    return str(rule)


def _check_design_fits(reader: Reader, parts: dict[str, Any]) -> None:
    """Cross-section checks: a session has one interaction per condition and needs that many
    distinct actors, faces, robot names and scenarios."""
    per_session = len(parts["conditions"])
    scenarios = len(parts["tasks"]) * len(parts["item_sets"].sets)
    for key, count in [
        ("actors", len(parts["actors"])),
        ("faces", len(parts["faces"])),
        ("robot_names", len(parts["robot_names"])),
    ]:
        if count < per_session:
            reader.problem(
                key, f"has {count}, a session of {per_session} interactions needs {per_session}"
            )
    if parts["tasks"] and parts["item_sets"].sets and scenarios < per_session:
        reader.problem(
            "item_sets",
            f"gives {scenarios} scenarios, a session of {per_session} needs {per_session}",
        )
    if parts["alternate_tasks"] and per_session > 1 and len(parts["tasks"]) == 1:
        reader.problem("design.alternate_tasks", "needs at least 2 tasks (or set it to false)")


def _config_of(parts: dict[str, Any], name_genders: dict[str, str]) -> dict[str, Any]:
    """The canonical snapshot: plain JSON types, keyed collections as lists with ``id``."""
    rule = parts["item_sets"]
    names: list[Any] = [
        {"name": name, "gender": name_genders[name]} if name in name_genders else name
        for name in parts["robot_names"]
    ]
    return {
        "id": parts["id"],
        "name": parts["name"],
        "description": parts["description"],
        "conditions": [_condition_config(c) for c in parts["conditions"]],
        "tasks": [
            {
                **{k: v for k, v in asdict(t).items() if k != "items"},
                "items": [asdict(i) for i in t.items],
            }
            for t in parts["tasks"]
        ],
        "item_sets": {
            "first_rank": rule.first_rank,
            "last_rank": rule.last_rank,
            "sets": list(rule.sets),
        },
        "suggestions_per_interaction": parts["suggestions_per_interaction"],
        "suggestion_rule": parts["suggestion_rule"],
        "design": {"alternate_tasks": parts["alternate_tasks"]},
        "actors": [_actor_config(a) for a in parts["actors"]],
        "faces": [asdict(f) for f in parts["faces"]],
        "robot_names": names,
        "personas": asdict(parts["personas"]),
        "questionnaires": [_questionnaire_config(q) for q in parts["questionnaires"]],
        **({"procedure": p} if (p := procedure_config(parts["procedure"])) else {}),
    }


def _condition_config(condition: Any) -> dict[str, Any]:
    """A condition as stored; ``renderer`` only where the study names one, so studies
    written before it existed keep their hash."""
    data = asdict(condition)
    if data["renderer"] is None:
        del data["renderer"]
    return data


def _actor_config(actor: Any) -> dict[str, Any]:
    """An actor as written; a Furhat voice only when set (older studies keep their hash)."""
    data = asdict(actor)
    furhat = data["voice"].pop("furhat")
    if furhat:
        data["voice"]["furhat"] = furhat[""] if list(furhat) == [""] else furhat
    return data


def _questionnaire_config(questionnaire: Any) -> dict[str, Any]:
    data = asdict(questionnaire)
    scale = {"points": data.pop("points"), "low": data.pop("low"), "high": data.pop("high")}
    items = []
    for item in questionnaire.items:
        entry = {k: v for k, v in asdict(item).items() if v != ""}
        if not item.numeric:
            entry.pop("reverse", None)
        if item.options:
            entry["options"] = [asdict(option) for option in item.options]
        else:
            entry.pop("options")
        if item.required == (item.type != "text"):
            # The default is not stored, so a snapshot from before the setting keeps its hash.
            entry.pop("required")
        items.append(entry)
    return {**data, "scale": scale, "items": items}
