"""Memory across runs: a small store per passenger profile, in a YAML file the user can read and edit.

The agent keeps what a passenger said that should outlive the run (``agent: {memory: {profile: NAME}}``):

- **preferences** the passenger stated as standing ones ("I always prefer passing on the left", "whenever an
  ambulance comes, pull over to the right", "I never want to go faster than 60 km/h"), each with what it means
  (:class:`Meaning`: ``preferred_side``, ``yield_side``, ``preferred_lane``, ``max_speed_mps``);
- **corrections** ("no, the other side" after a call): the message corrected, the calls that were wrong and the
  calls that were right.

The file (one per profile; ``file:`` or ``$AGENTIC_MPC_MEMORY_DIR/<profile>.yaml``, default directory
``~/.agentic-mpc/memory``)::

    version: 1
    profile: alice
    entries:
    - id: 1
      kind: preference
      said: I always prefer passing obstacles on the left.
      means: {preferred_side: left}
      run: paper_steering_preference_plain-seed0
      time: '2026-12-08T10:15:02+00:00'
    - id: 2
      kind: correction
      said: No, the other side.
      corrects: Keep the obstacles on the left.
      wrong: [{tool: set_preferred_steering_direction, arguments: {direction: right}}]
      right: [{tool: set_preferred_steering_direction, arguments: {direction: left}}]

The user may edit it while nothing runs or during a run: the store re-reads it when it changed, and every
write re-reads it first and only adds this run's new entries (new ids after the file's largest), then
replaces the file atomically (a temporary file in the same directory, ``os.replace``; a lock file keeps two
runs from writing at once). YAML comments are not kept by a write: an entry's ``note:`` is. A file that is
malformed or of another version is a :class:`MemoryFileError` naming the file and the entry; with
``on_error: ignore`` the run goes on without memory (a warning, and the file is never written).

Retrieval (:meth:`MemoryStore.similar`) is TF-IDF over words with cosine similarity, no model and no download;
the standing preferences (:meth:`MemoryStore.preferences`) are the latest entry per key. What the agent does
with them: :mod:`agentic_mpc.agent.memory_recall`; the rules backend: :mod:`agentic_mpc.agent.memory_rules`.
"""

from __future__ import annotations

import logging
import math
import os
import re
import tempfile
from collections import Counter
from contextlib import contextmanager
from datetime import UTC, datetime
from pathlib import Path
from typing import Any, Literal

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from agentic_mpc.frozen_config import FrozenConfig

logger = logging.getLogger(__name__)

MEMORY_VERSION = 1
"""The file format this code reads and writes (the file's ``version:``)."""
MEMORY_DIR_ENV = "AGENTIC_MPC_MEMORY_DIR"
DEFAULT_MEMORY_DIR = Path("~/.agentic-mpc/memory")
PREFERENCE_KEYS = ("preferred_side", "yield_side", "preferred_lane", "max_speed_mps")


class MemorySettings(FrozenConfig):
    """A scenario's ``agent: {memory: {...}}`` (``--agent memory.profile=alice``)."""

    profile: str = Field(..., pattern=r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,63}$", description="the passenger's profile")
    file: Path | None = Field(None, description="the profile's YAML file (default: $AGENTIC_MPC_MEMORY_DIR or "
                                                "~/.agentic-mpc/memory, then <profile>.yaml)")
    on_error: Literal["fail", "ignore"] = Field(
        "fail", description="a malformed file or one of another version: fail (the run does not start) or ignore "
                            "(a warning; the run goes on without memory and the file is left as it is)")
    learn: bool = Field(True, description="record new preferences and corrections (false: only read the file)")
    examples: int = Field(3, ge=0, le=10, description="the most similar entries given with each message")
    min_similarity: float = Field(0.2, ge=0.0, le=1.0, description="an entry less similar is not an example")

    def path(self) -> Path:
        if self.file is not None:
            return self.file.expanduser()
        return Path(os.environ.get(MEMORY_DIR_ENV) or DEFAULT_MEMORY_DIR).expanduser() / f"{self.profile}.yaml"


class Meaning(BaseModel):
    """What a standing preference means (at least one key)."""

    model_config = ConfigDict(extra="forbid")
    preferred_side: Literal["left", "right"] | None = None
    """The side to evade obstacles and to overtake on when a message names none."""
    yield_side: Literal["left", "right"] | None = None
    """Where to pull over for an emergency vehicle when a message names no side."""
    preferred_lane: str | None = None
    """A lane label to drive in (for a model; the rules do not act on it)."""
    max_speed_mps: float | None = Field(None, gt=0, allow_inf_nan=False)
    """A speed not to exceed unless the passenger names a higher one."""

    def items(self) -> dict[str, Any]:
        return {key: value for key in PREFERENCE_KEYS if (value := getattr(self, key)) is not None}


class Call(BaseModel):
    model_config = ConfigDict(extra="forbid")
    tool: str = Field(..., min_length=1)
    arguments: dict[str, Any] = Field(default_factory=dict)

    def describe(self) -> str:
        return f"{self.tool}({', '.join(f'{k}={v!r}' for k, v in self.arguments.items())})"


class MemoryEntry(BaseModel):
    """One thing remembered (see the module docstring for the fields)."""

    model_config = ConfigDict(extra="forbid")
    id: int = Field(..., ge=1)
    kind: Literal["preference", "correction"]
    said: str = Field(..., min_length=1)
    means: Meaning | None = None
    corrects: str | None = None
    wrong: list[Call] = Field(default_factory=list)
    right: list[Call] = Field(default_factory=list)
    run: str | None = None
    time: str | None = None
    note: str | None = None

    @model_validator(mode="after")
    def _complete(self) -> MemoryEntry:
        if self.kind == "preference" and (self.means is None or not self.means.items()):
            raise ValueError("a preference needs 'means' with one of " + ", ".join(PREFERENCE_KEYS))
        if self.kind == "correction" and (not self.corrects or not self.right):
            raise ValueError("a correction needs 'corrects' (the message) and 'right' (the calls it wanted)")
        return self

    @property
    def text(self) -> str:
        """What retrieval compares a message with: the message corrected, or what was said."""
        return self.corrects if self.kind == "correction" and self.corrects else self.said


def _plain(entry: MemoryEntry) -> dict[str, Any]:
    data = entry.model_dump(mode="json", exclude_none=True)
    if entry.kind == "preference":
        data.pop("wrong", None), data.pop("right", None)
    if entry.means is not None:
        data["means"] = entry.means.items()
    return data


class MemoryFileError(ValueError):
    """A memory file that cannot be used: says the file and, where it is one entry, which."""

    def __init__(self, path: Path, problem: str, entry: str | None = None) -> None:
        self.path, self.problem, self.entry = path, problem, entry
        where = f"memory file {path}" + (f", {entry}" if entry else "")
        super().__init__(f"{where}: {problem}")


def read_memory_file(path: Path, profile: str | None = None) -> list[MemoryEntry]:
    """The entries of ``path`` (none if it does not exist); :class:`MemoryFileError` if it cannot be used."""
    try:
        text = path.read_text(encoding="utf-8")
    except FileNotFoundError:
        return []
    except (OSError, UnicodeDecodeError) as error:
        raise MemoryFileError(path, f"cannot be read ({error})") from None
    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as error:
        mark = getattr(error, "problem_mark", None)
        line = f" at line {mark.line + 1}" if mark is not None else ""
        raise MemoryFileError(path, f"not valid YAML{line}: {getattr(error, 'problem', None) or error}") from None
    if data is None:
        return []
    if not isinstance(data, dict):
        raise MemoryFileError(path, f"expected a mapping with version, profile and entries, got {type(data).__name__}")
    unknown = sorted(set(data) - {"version", "profile", "entries"})
    if unknown:
        raise MemoryFileError(path, f"unknown key(s) {', '.join(map(str, unknown))} (expected version, profile, entries)")
    version = data.get("version")
    if version is None:
        raise MemoryFileError(path, f"no 'version' (this agentic-mpc reads version {MEMORY_VERSION})")
    if version != MEMORY_VERSION:
        raise MemoryFileError(path, f"version {version!r} is not one this agentic-mpc reads (version {MEMORY_VERSION})")
    if profile is not None and data.get("profile") not in (None, profile):
        raise MemoryFileError(path, f"it is profile {data.get('profile')!r}'s, not {profile!r}'s")
    raw = data.get("entries") or []
    if not isinstance(raw, list):
        raise MemoryFileError(path, f"'entries' must be a list, got {type(raw).__name__}")
    entries: list[MemoryEntry] = []
    seen: set[int] = set()
    for index, item in enumerate(raw, start=1):
        name = f"entry {index}" + (f" (id {item.get('id')})" if isinstance(item, dict) and "id" in item else "")
        try:
            entry = MemoryEntry.model_validate(item)
        except ValidationError as error:
            problems = "; ".join((f"{'.'.join(map(str, e['loc']))}: " if e["loc"] else "")
                                 + e["msg"].removeprefix("Value error, ") for e in error.errors())
            raise MemoryFileError(path, problems, name) from None
        if entry.id in seen:
            raise MemoryFileError(path, f"id {entry.id} is used by an earlier entry", name)
        seen.add(entry.id)
        entries.append(entry)
    return entries


def write_memory_file(path: Path, profile: str, entries: list[MemoryEntry]) -> None:
    """Replace ``path`` atomically with ``entries``."""
    path.parent.mkdir(parents=True, exist_ok=True)
    header = (f"# agentic-mpc agent memory of passenger profile {profile!r}: edit it freely (docs/llm-backends.md, "
              "Memory).\n# Comments are not kept when the agent writes; an entry's 'note:' is.\n")
    body = yaml.safe_dump({"version": MEMORY_VERSION, "profile": profile, "entries": [_plain(e) for e in entries]},
                          sort_keys=False, allow_unicode=True, width=110)
    handle, temporary = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(handle, "w", encoding="utf-8") as out:
            out.write(header + body)
            out.flush()
            os.fsync(out.fileno())
        os.replace(temporary, path)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise


@contextmanager
def _locked(path: Path):
    """Hold ``<file>.lock`` (two runs of one profile write one after the other)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    with open(path.with_name(path.name + ".lock"), "a") as lock:
        try:
            import fcntl

            fcntl.flock(lock.fileno(), fcntl.LOCK_EX)
        except ImportError:  # not POSIX: no lock
            pass
        yield


_STOP_WORDS = frozenset(re.findall(
    r"\w+", "a an the to of is are be it its this that these those we us our i me my you your please and or so on at "
            "in for with do can could would will shall should just let there here some"))


def words(text: str) -> list[str]:
    """Lower-case words without the commonest (``left``, ``right``, ``not``, ``no`` are kept)."""
    return [w for w in re.findall(r"[a-z0-9]+", text.lower().replace("'", "")) if w not in _STOP_WORDS]


def tfidf_similarities(query: str, documents: list[str]) -> list[float]:
    """Cosine similarity of ``query`` with each document over TF-IDF word vectors (smoothed IDF, the query
    counted among the documents)."""
    bags = [Counter(words(d)) for d in documents]
    asked = Counter(words(query))
    n = len(bags) + 1
    frequency = Counter(w for bag in [*bags, asked] for w in bag)
    idf = {w: math.log((1 + n) / (1 + f)) + 1.0 for w, f in frequency.items()}

    def vector(bag: Counter[str]) -> dict[str, float]:
        return {w: c * idf[w] for w, c in bag.items()}

    q = vector(asked)
    q_norm = math.sqrt(sum(v * v for v in q.values()))
    out = []
    for bag in bags:
        d = vector(bag)
        norm = math.sqrt(sum(v * v for v in d.values()))
        dot = sum(v * d.get(w, 0.0) for w, v in q.items())
        out.append(dot / (q_norm * norm) if q_norm and norm else 0.0)
    return out


class MemoryStore:
    """One profile's memory, backed by its file (see the module docstring)."""

    def __init__(self, settings: MemorySettings, run: str | None = None) -> None:
        self.settings = settings
        self.path = settings.path()
        self.run = run
        self._entries = read_memory_file(self.path, settings.profile)  # MemoryFileError: the caller decides
        self._stamp = self._file_stamp()
        self._pending: list[MemoryEntry] = []  # this run's, not yet in the file
        self.write_error: str | None = None

    @property
    def profile(self) -> str:
        return self.settings.profile

    def _file_stamp(self) -> tuple[int, int] | None:
        try:
            stat = self.path.stat()
        except OSError:
            return None
        return stat.st_mtime_ns, stat.st_size

    def refresh(self) -> None:
        """Re-read the file if someone changed it (a file broken meanwhile: the last good entries stay)."""
        stamp = self._file_stamp()
        if stamp == self._stamp:
            return
        try:
            self._entries = read_memory_file(self.path, self.profile)
        except MemoryFileError as error:
            logger.warning("%s; the entries read before stay in use", error)
        self._stamp = stamp

    @property
    def entries(self) -> list[MemoryEntry]:
        return [*self._entries, *self._pending]

    def add(self, kind: str, said: str, **fields: Any) -> MemoryEntry:
        """Remember one entry (and write the file, if ``learn``)."""
        entry = MemoryEntry(id=max((e.id for e in self.entries), default=0) + 1, kind=kind, said=said, run=self.run,
                            time=datetime.now(UTC).isoformat(timespec="seconds"), **fields)
        self._pending.append(entry)
        self.save()
        return next((e for e in reversed(self.entries) if (e.said, e.time, e.kind) == (said, entry.time, kind)), entry)

    def replace(self, entry: MemoryEntry, **changes: Any) -> None:
        """Change an entry of this run (a preference its correction showed was misread)."""
        for index, pending in enumerate(self._pending):
            if pending.id == entry.id:
                self._pending[index] = pending.model_copy(update=changes)
                return
        for index, known in enumerate(self._entries):
            if known.id == entry.id and known.run == self.run and self.run is not None:
                self._entries[index] = known.model_copy(update=changes)
                self._pending.append(self._entries.pop(index))
                return

    def save(self) -> bool:
        """Write this run's new entries after the file's (re-read first: the user's edits stay); False (and
        :attr:`write_error`) if the file cannot be written or has become unreadable."""
        if not self.settings.learn or not self._pending:
            return True
        try:
            with _locked(self.path):
                on_disk = read_memory_file(self.path, self.profile)
                ours = {(e.id, e.said, e.time) for e in self._pending}
                kept = [e for e in on_disk if (e.id, e.said, e.time) not in ours]  # the user's, as they are now
                used = {e.id for e in kept}
                mine = []
                for entry in self._pending:
                    if entry.id in used:  # the user added an entry with this id meanwhile
                        entry = entry.model_copy(update={"id": max(used) + 1})
                    used.add(entry.id)
                    mine.append(entry)
                write_memory_file(self.path, self.profile, [*kept, *mine])
                self._entries, self._pending = [*kept, *mine], []
                self._stamp = self._file_stamp()
                self.write_error = None
                return True
        except (MemoryFileError, OSError) as error:
            self.write_error = f"the memory was not written: {error}"
            logger.warning("%s", self.write_error)
            return False

    def preferences(self) -> dict[str, tuple[Any, MemoryEntry]]:
        """The standing preferences: each key's latest value, with the entry that says it."""
        found: dict[str, tuple[Any, MemoryEntry]] = {}
        for entry in self.entries:
            if entry.kind == "preference" and entry.means is not None:
                for key, value in entry.means.items().items():
                    found[key] = (value, entry)
        return found

    def similar(self, text: str, k: int | None = None, kind: str | None = None) -> list[tuple[float, MemoryEntry]]:
        """The ``k`` entries most similar to ``text`` (at least ``min_similarity``), best first."""
        candidates = [e for e in self.entries if kind is None or e.kind == kind]
        if not candidates:
            return []
        scores = tfidf_similarities(text, [e.text for e in candidates])
        ranked = sorted(zip(scores, candidates, strict=True), key=lambda pair: (-pair[0], -pair[1].id))
        limit = self.settings.examples if k is None else k
        return [(round(s, 3), e) for s, e in ranked if s >= self.settings.min_similarity][:limit]

    def to_json(self) -> dict[str, Any]:
        """What ``agent://memory`` shows."""
        return {"profile": self.profile, "file": str(self.path), "version": MEMORY_VERSION,
                "learn": self.settings.learn, "write_error": self.write_error,
                "preferences": {key: {"value": value, "entry": entry.id}
                                for key, (value, entry) in self.preferences().items()},
                "entries": [_plain(e) for e in self.entries]}


def open_memory(settings: MemorySettings | None, run: str | None = None) -> tuple[MemoryStore | None, str | None]:
    """(the store, None), (None, None) without settings, or with ``on_error: ignore`` (None, the problem) for a
    file that cannot be used; with ``on_error: fail`` its :class:`MemoryFileError` is raised."""
    if settings is None:
        return None, None
    try:
        return MemoryStore(settings, run), None
    except MemoryFileError as error:
        if settings.on_error == "fail":
            raise
        logger.warning("%s; going on without memory (on_error: ignore), the file is left as it is", error)
        return None, str(error)
