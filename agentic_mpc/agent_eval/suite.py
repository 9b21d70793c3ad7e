"""The evaluation suite: a YAML file of passenger messages (single ones and multi-turn dialogues), each turn
with the tool calls it expects and their argument tolerances. :func:`load_suite` reads and checks it;
every problem names the file and the case id.

File layout::

    version: 1
    worlds:                      # the roads a case starts on, by name
      lefthand: {scenario: paper_steering_preference_plain}   # a shipped scenario, or a path
    categories:                  # name: what it measures
      side: steering preference around obstacles
    cases:
      - id: side-right-paper
        category: side
        world: lefthand
        message: "Let's try to avoid obstacles from the right, shall we?"
        expect: [{tool: set_preferred_steering_direction, args: {direction: right}}]
      - id: undo-after-right
        category: undo
        world: lefthand
        turns:                   # a dialogue: one agent, its history kept; every turn is scored
          - {message: "Avoid obstacles from the right.", expect: [...]}
          - {message: "Go back to normal.", expect: [...], alternatives: [[...]]}

``expect`` lists the calls a turn must make (``[]``: no call at all); ``alternatives`` lists other call
lists that are right too; ``cites`` lists documents (knowledge ids) one of which the answer must name, in a
world with ``knowledge: true`` (the agent then has the knowledge server; its searches are not scored as
calls). ``tool`` is a name or a list of names (any of them). ``args`` constrains each
argument (an argument not named is free):

- a plain value: that value (numbers within 0.01);
- ``{approx: X, tol: T}``: within T of X; ``{range: [LO, HI]}``: LO <= value <= HI;
- ``{relative: [LO, HI]}``: between LO and HI times the reference speed tracked when the turn starts
  ("a bit faster");
- ``{one_of: [A, B]}``; ``{any: true}``.

Relative paths (``scenario``) are read from the suite file's directory, then from the repository root.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from agentic_mpc.agent_eval.expectations import NUMBER_TOLERANCE, CallSpec, Constraint, Turn, is_number
from agentic_mpc.mcp.protocol import ToolName, is_tool_name
from agentic_mpc.shipped import UnknownScenario, scenario_path

DEFAULT_SUITE = Path(__file__).resolve().parent / "suite.yaml"
_CASE_ID = re.compile(r"^[A-Za-z0-9][\w.-]{0,79}$")


class SuiteError(ValueError):
    """A suite file that cannot be used; ``problems`` lists every problem, each naming the file and case."""

    def __init__(self, problems: list[str]) -> None:
        self.problems = problems
        more = f" (and {len(problems) - 1} more problem(s))" if len(problems) > 1 else ""
        super().__init__(f"{problems[0]}{more}")


@dataclass(frozen=True, slots=True)
class Case:
    id: str
    category: str
    world: str
    turns: tuple[Turn, ...]
    note: str = ""


@dataclass(frozen=True, slots=True)
class WorldRef:
    """A road a case starts on: a scenario file (and variant) whose world and initial specification are used."""

    name: str
    scenario: Path
    variant: str | None = None
    knowledge: bool = False
    """The agent gets the shipped knowledge server (its calls are not scored as calls)."""


@dataclass(frozen=True, slots=True)
class Suite:
    path: Path
    worlds: dict[str, WorldRef]
    categories: dict[str, str]
    cases: tuple[Case, ...]

    def select(self, categories: list[str] | None = None, case_ids: list[str] | None = None,
               limit: int | None = None, per_category: int | None = None) -> tuple[Case, ...]:
        """The cases of the given categories / ids (all if None), at most ``per_category`` of each category
        (the first ones), the first ``limit`` of them."""
        for name in categories or ():
            if name not in self.categories:
                raise SuiteError([f"{self.path}: no category {name!r} (choose from {', '.join(self.categories)})"])
        known = {case.id for case in self.cases}
        for case_id in case_ids or ():
            if case_id not in known:
                raise SuiteError([f"{self.path}: no case {case_id!r}"])
        chosen = tuple(c for c in self.cases if (not categories or c.category in categories)
                       and (not case_ids or c.id in case_ids))
        if per_category is not None:
            chosen = tuple(c for c in chosen
                           if [o.id for o in chosen if o.category == c.category].index(c.id) < per_category)
        return chosen[:limit] if limit is not None else chosen


# ---------------------------------------------------------------------------------------------- parsing
class _Problem(Exception):
    """One problem inside a case; the caller adds the file and the case id."""


def _constraint(name: str, raw: Any) -> Constraint:
    if not isinstance(raw, dict):
        if isinstance(raw, list | tuple) or raw is None:
            raise _Problem(f"argument {name!r}: a value or a constraint mapping, got {raw!r}")
        return Constraint("exact", raw)
    if len(raw) != 1 and set(raw) != {"approx", "tol"}:
        raise _Problem(f"argument {name!r}: one of approx (with tol), range, relative, one_of, any; got {sorted(raw)}")
    if "approx" in raw:
        centre, tol = raw["approx"], raw.get("tol", NUMBER_TOLERANCE)
        if not (is_number(centre) and is_number(tol) and tol >= 0):
            raise _Problem(f"argument {name!r}: approx and tol must be numbers, tol >= 0")
        return Constraint("approx", None, float(centre) - float(tol), float(centre) + float(tol))
    kind, value = next(iter(raw.items()))
    if kind in ("range", "relative"):
        if not (isinstance(value, list) and len(value) == 2 and all(map(is_number, value)) and value[0] <= value[1]):
            raise _Problem(f"argument {name!r}: {kind} must be [LOW, HIGH] numbers with LOW <= HIGH, got {value!r}")
        return Constraint(kind, None, float(value[0]), float(value[1]))
    if kind == "one_of":
        if not isinstance(value, list) or not value:
            raise _Problem(f"argument {name!r}: one_of must be a non-empty list")
        return Constraint("one_of", tuple(value))
    if kind == "any":
        if value is not True:
            raise _Problem(f"argument {name!r}: write any: true")
        return Constraint("any")
    raise _Problem(f"argument {name!r}: unknown constraint {kind!r} (approx, range, relative, one_of, any)")


def _call(raw: Any) -> CallSpec:
    if not isinstance(raw, dict) or "tool" not in raw:
        raise _Problem(f"an expected call must be a mapping with 'tool', got {raw!r}")
    extra = set(raw) - {"tool", "args"}
    if extra:
        raise _Problem(f"unknown key(s) {sorted(extra)} in an expected call (tool, args)")
    tools = raw["tool"] if isinstance(raw["tool"], list) else [raw["tool"]]
    for tool in tools:
        if not isinstance(tool, str) or not is_tool_name(tool):
            raise _Problem(f"not one of the controller's tools: {tool!r} (run_<lane>_lane, "
                           f"{', '.join(ToolName)})")
    args = raw.get("args") or {}
    if not isinstance(args, dict):
        raise _Problem(f"args must be a mapping, got {args!r}")
    return CallSpec(tuple(tools), tuple((str(k), _constraint(str(k), v)) for k, v in args.items()))


def _calls(raw: Any, what: str) -> tuple[CallSpec, ...]:
    if not isinstance(raw, list):
        raise _Problem(f"{what} must be a list of calls ([] for no call), got {raw!r}")
    return tuple(_call(item) for item in raw)


def _turn(raw: Any) -> Turn:
    if not isinstance(raw, dict):
        raise _Problem(f"a turn must be a mapping, got {raw!r}")
    extra = set(raw) - {"message", "expect", "alternatives", "cites"}
    if extra:
        raise _Problem(f"unknown key(s) {sorted(extra)} in a turn (message, expect, alternatives, cites)")
    cites = raw.get("cites") or []
    if not isinstance(cites, list) or not all(isinstance(c, str) and c for c in cites):
        raise _Problem("cites must be a list of document ids")
    message = raw.get("message")
    if not isinstance(message, str) or not message.strip():
        raise _Problem("every turn needs a non-empty message")
    if "expect" not in raw:
        raise _Problem(f"the turn {message!r} has no expect (write expect: [] for no call)")
    alternatives = raw.get("alternatives") or []
    if not isinstance(alternatives, list):
        raise _Problem("alternatives must be a list of call lists")
    return Turn(message, _calls(raw["expect"], "expect"),
                tuple(_calls(a, "each alternative") for a in alternatives), tuple(cites))


def _case(raw: dict[str, Any], worlds: dict[str, WorldRef], categories: dict[str, str]) -> Case:
    extra = set(raw) - {"id", "category", "world", "message", "expect", "alternatives", "cites", "turns", "note"}
    if extra:
        raise _Problem(f"unknown key(s) {sorted(extra)}")
    if raw.get("category") not in categories:
        raise _Problem(f"category {raw.get('category')!r} is not declared (declared: {', '.join(categories)})")
    if raw.get("world") not in worlds:
        raise _Problem(f"world {raw.get('world')!r} is not declared (declared: {', '.join(worlds)})")
    if ("turns" in raw) == ("message" in raw):
        raise _Problem("give either message + expect (one turn) or turns (a dialogue)")
    if "turns" in raw:
        if not isinstance(raw["turns"], list) or not raw["turns"]:
            raise _Problem("turns must be a non-empty list")
        if any(key in raw for key in ("expect", "alternatives")):
            raise _Problem("a dialogue's expect and alternatives belong in its turns")
        turns = tuple(_turn(t) for t in raw["turns"])
    else:
        turns = (_turn({k: raw[k] for k in ("message", "expect", "alternatives", "cites") if k in raw}),)
    return Case(str(raw["id"]), str(raw["category"]), str(raw["world"]), turns, str(raw.get("note") or ""))


def _resolve(path: str, suite_file: Path) -> Path:
    """A world's scenario: a path (absolute, or relative to the suite file), else a shipped scenario's name
    (``scenarios/NAME.yaml``, as suites said when they ran from a checkout, is the shipped NAME too)."""
    candidate = Path(path).expanduser()
    if candidate.is_absolute():
        return candidate
    if (suite_file.parent / candidate).is_file():
        return (suite_file.parent / candidate).resolve()
    try:
        return scenario_path(candidate.name if candidate.parent == Path("scenarios") else path)
    except UnknownScenario:
        return suite_file.parent / candidate  # reported as missing by the caller


def load_suite(path: str | Path | None = None) -> Suite:
    """Read and check a suite file (default: the shipped one); :class:`SuiteError` lists every problem."""
    path = Path(path) if path is not None else DEFAULT_SUITE
    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8"))
    except OSError as error:
        raise SuiteError([f"{path}: cannot be read ({error.strerror or error})"]) from None
    except yaml.YAMLError as error:
        raise SuiteError([f"{path}: not YAML: {' '.join(str(error).split())}"]) from None
    if not isinstance(data, dict):
        raise SuiteError([f"{path}: expected a mapping with worlds, categories and cases"])
    problems: list[str] = []
    extra = set(data) - {"version", "description", "worlds", "categories", "cases"}
    if extra:
        problems.append(f"{path}: unknown top-level key(s) {sorted(extra)}")
    worlds: dict[str, WorldRef] = {}
    raw_worlds = data.get("worlds")
    if not isinstance(raw_worlds, dict) or not raw_worlds:
        problems.append(f"{path}: worlds must map names to {{scenario: FILE}}")
        raw_worlds = {}
    for name, raw in raw_worlds.items():
        if not isinstance(raw, dict) or not isinstance(raw.get("scenario"), str) or set(raw) - {
                "scenario", "variant", "description", "knowledge"}:
            problems.append(f"{path}: world {name!r}: expected {{scenario: FILE, variant: NAME, knowledge: BOOL}} "
                            "(variant and knowledge optional)")
            continue
        scenario = _resolve(raw["scenario"], path)
        if not scenario.is_file():
            problems.append(f"{path}: world {name!r}: no scenario file {raw['scenario']!r}")
        worlds[str(name)] = WorldRef(str(name), scenario, raw.get("variant"), bool(raw.get("knowledge", False)))
    categories = data.get("categories")
    if not isinstance(categories, dict) or not categories:
        problems.append(f"{path}: categories must map names to descriptions")
        categories = {}
    categories = {str(k): str(v) for k, v in categories.items()}
    raw_cases = data.get("cases")
    if not isinstance(raw_cases, list) or not raw_cases:
        problems.append(f"{path}: cases must be a non-empty list")
        raw_cases = []
    cases: list[Case] = []
    seen: set[str] = set()
    for index, raw in enumerate(raw_cases):
        case_id = raw.get("id") if isinstance(raw, dict) else None
        where = f"{path}: case {case_id!r}" if isinstance(case_id, str) else f"{path}: case #{index + 1} (no id)"
        if not isinstance(raw, dict) or not isinstance(case_id, str) or not _CASE_ID.match(case_id):
            problems.append(f"{where}: every case needs an id (letters, digits, '-', '_', '.')")
            continue
        if case_id in seen:
            problems.append(f"{where}: duplicate id")
            continue
        seen.add(case_id)
        try:
            cases.append(_case(raw, worlds, categories))
        except _Problem as problem:
            problems.append(f"{where}: {problem}")
    if problems:
        raise SuiteError(problems)
    return Suite(path, worlds, categories, tuple(cases))
