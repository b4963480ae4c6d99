"""The skill library: the predefined skills (from config) and the demonstrated ones the operator taught.

A tree leaf runs one library skill. Predefined skills and conditions (kind ``condition``: a check of the world
that moves nothing, e.g. ProductInHand) are served by ``/skills/<name>``; demonstrated (or learned)
skills are replayed by ``/skills/ReplaySkill`` from their recorded file, which :meth:`SkillLibrary.add_demonstrated`
validates with :func:`teleteach.core.skill_file.load` before accepting it. A saved entry whose file went missing or bad
since stays in the library as *unavailable* (:meth:`SkillLibrary.with_checked_files`): shown, never run or inserted.
"""

import dataclasses
import pathlib
import typing

import yaml

from teleteach.core import skill_file

PREDEFINED = "predefined"
CONDITION = "condition"  # served like a predefined skill; its failure is an answer, not a reason to ask for help


class LibraryError(ValueError):
    """A skill cannot join the library, or a library file is malformed."""


@dataclasses.dataclass(frozen=True)
class SkillEntry:
    """One skill the tree can use."""

    name: str
    kind: str = PREDEFINED
    data_file: str = ""
    description: str = ""
    problem: str = ""  # why a demonstrated skill cannot run (its file is missing or bad); "" when it can

    @property
    def demonstrated(self) -> bool:
        """True for taught skills, which run through ReplaySkill."""
        return self.kind not in (PREDEFINED, CONDITION)

    @property
    def available(self) -> bool:
        """Whether the skill can run (its file was valid when the library was loaded)."""
        return not self.problem


class SkillLibrary:
    """Skills by name, in the order they were added (predefined first)."""

    def __init__(self, entries: typing.Iterable[SkillEntry] = ()):
        self._entries: typing.Dict[str, SkillEntry] = {}
        for entry in entries:
            if not entry.name or not entry.name.isidentifier():
                raise LibraryError(f"skill name {entry.name!r} must be a non-empty identifier")
            if entry.name in self._entries:
                raise LibraryError(f"skill {entry.name!r} is listed twice")
            if entry.kind not in (PREDEFINED, CONDITION) and entry.kind not in skill_file.KINDS:
                raise LibraryError(f"skill {entry.name!r} has unknown kind {entry.kind!r}")
            self._entries[entry.name] = entry

    def __contains__(self, name: str) -> bool:
        return name in self._entries

    def __iter__(self) -> typing.Iterator[SkillEntry]:
        return iter(self._entries.values())

    def __len__(self) -> int:
        return len(self._entries)

    def get(self, name: str) -> typing.Optional[SkillEntry]:
        """The skill called ``name``, or None."""
        return self._entries.get(name)

    def add_demonstrated(self, name: str, kind: str, data_file: str, data_root: pathlib.Path) -> SkillEntry:
        """Validate a recorded skill and add it; raise :class:`LibraryError` saying what is wrong.

        Args:
            name: library name (an identifier, not yet in the library)
            kind: stiffness | shared_control | dmp (must match the file)
            data_file: path of the skill file; relative paths are taken from ``data_root``
            data_root: the data directory
        """
        if not name:
            raise LibraryError("empty skill name")
        if not name.isidentifier():
            raise LibraryError(f"skill name {name!r} must be an identifier (letters, digits, _)")
        if name in self._entries:
            raise LibraryError(f"a skill named {name!r} is already in the library ({self._entries[name].kind})")
        if kind not in skill_file.KINDS:
            raise LibraryError(f"unknown skill kind {kind!r}; expected one of {', '.join(skill_file.KINDS)}")
        if not data_file:
            raise LibraryError("empty data file")
        path = pathlib.Path(data_file).expanduser()
        if not path.is_absolute():
            path = data_root / path
        try:
            skill = skill_file.load(path)
        except skill_file.SkillFileError as error:
            raise LibraryError(str(error)) from None
        if skill.kind != kind:
            raise LibraryError(f"skill file {path} holds a {skill.kind} skill, not a {kind} skill")
        entry = SkillEntry(name=name, kind=kind, data_file=str(path.resolve()))
        self._entries[name] = entry
        return entry

    def with_checked_files(self) -> "SkillLibrary":
        """This library, with each demonstrated skill whose file does not load marked unavailable (and why)."""
        entries = []
        for entry in self._entries.values():
            problem = ""
            if entry.demonstrated:
                try:
                    skill = skill_file.load(entry.data_file)
                    if skill.kind != entry.kind:
                        problem = f"skill file {entry.data_file} holds a {skill.kind} skill, not a {entry.kind} skill"
                except skill_file.SkillFileError as error:
                    problem = str(error)
                    if entry.data_file not in problem:
                        problem = f"skill file {entry.data_file}: {problem}"
            entries.append(dataclasses.replace(entry, problem=problem))
        return SkillLibrary(entries)

    def to_dict(self) -> typing.Dict[str, typing.Any]:
        """Plain data for yaml (the format of config/skills.yaml)."""
        skills = []
        for entry in self._entries.values():
            item: typing.Dict[str, str] = {"name": entry.name, "kind": entry.kind}
            if entry.data_file:
                item["data_file"] = entry.data_file
            if entry.description:
                item["description"] = entry.description
            skills.append(item)
        return {"skills": skills}

    @classmethod
    def from_dict(cls, data: typing.Any, source: str = "skill library") -> "SkillLibrary":
        """Build from plain data: ``{skills: [name | {name, kind, data_file, description}]}``."""
        if not isinstance(data, dict) or not isinstance(data.get("skills"), list):
            raise LibraryError(f"{source}: expected a mapping with a 'skills' list")
        entries = []
        for item in data["skills"]:
            if isinstance(item, str):
                item = {"name": item}
            if not isinstance(item, dict) or not isinstance(item.get("name"), str):
                raise LibraryError(f"{source}: each skill needs a name, got {item!r}")
            unknown = set(item) - {"name", "kind", "data_file", "description"}
            if unknown:
                raise LibraryError(f"{source}: skill {item['name']!r} has unknown fields {sorted(unknown)}")
            entries.append(
                SkillEntry(
                    name=item["name"],
                    kind=str(item.get("kind", PREDEFINED)),
                    data_file=str(item.get("data_file", "")),
                    description=str(item.get("description", "")),
                )
            )
        try:
            return cls(entries)
        except LibraryError as error:
            raise LibraryError(f"{source}: {error}") from None

    @classmethod
    def load(cls, path: typing.Union[str, pathlib.Path], _read: typing.Tuple[pathlib.Path, ...] = ()) -> "SkillLibrary":
        """Read a library yaml file (config/skills.yaml or a saved library).

        ``extends: <file>`` (relative to this one) puts that library's skills before this file's.
        """
        path = pathlib.Path(path).resolve()
        if path in _read:
            raise LibraryError(f"skill library {path} extends itself (through {', '.join(map(str, _read))})")
        try:
            data = yaml.safe_load(path.read_text())
        except (OSError, yaml.YAMLError) as error:
            raise LibraryError(f"cannot read skill library {path}: {error}") from None
        if isinstance(data, dict) and "extends" in data:
            data = dict(data)
            base = cls.load(path.parent / str(data.pop("extends")), (*_read, path))
            data["skills"] = [*base.to_dict()["skills"], *(data.get("skills") or [])]
        return cls.from_dict(data, source=str(path))
