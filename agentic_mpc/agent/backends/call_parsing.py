"""Tool calls written as text, from any model: what a chat model answered, split into calls and a reply.

Endpoints parse native ``tool_calls`` only for the models and templates they know; many models (the Qwen
coders, small instruct models, a base model behind a plain chat template) write the call into the text
instead. Understood here, when it names a listed tool:

- a JSON object ``{"name": ..., "arguments": {...}}`` (also ``"parameters"``, ``"args"``, ``"input"``,
  arguments as a JSON string, the OpenAI shape ``{"function": {...}}``, ``{"tool_call": {...}}``,
  ``{"<tool name>": {...arguments}}``) or a list of them;
- bare in the text, inside Markdown code fences (```json ... ```), or inside ``<tool_call>`` tags;
- with the doubled braces a model copies from its template (``{{"name": ..., "arguments": {{...}}}}``), or
  Python literals (single quotes);
- a Python-style call of a listed tool, ``run_left_lane(v_ref=0)``.

``{"reply": "..."}`` (the structured mode's no-call answer, also ``"response"``) is a reply, not a call.

Text that looks like a failed call (JSON that does not parse, a JSON answer that is no call, an unknown tool
name, a truncated object) becomes a :class:`~agentic_mpc.agent.messages.ToolCall` with ``error`` set: the
agent answers it with a tool error that says what was expected and which tools exist, so the model can try
again, and the step's report and transcript carry the reason. Plain prose stays a reply without a call.
"""

from __future__ import annotations

import ast
import json
import re
from collections.abc import Callable, Collection
from typing import Any

from agentic_mpc.agent.messages import ToolCall

TEXT_CALL_PREFIX = "text-call-"
"""Ids of calls read from text start with this: the history echoes them to the model as the text it wrote."""

UNPARSED = "unparsed_tool_call"
"""The name of a call that could not be read (it is never a listed tool)."""

_ARGUMENT_KEYS = ("arguments", "parameters", "args", "input", "params")
_NAME_KEYS = ("name", "tool", "tool_name", "function_name")
_BARE_CALL = re.compile(r"\s*`?[A-Za-z_][\w]*\s*\([^()]*\)`?\s*\.?\s*")
"""A reply that is nothing but ``tool(arg=value)`` (a small model in json_schema mode wrote its call so)."""
_REPLY_KEYS = ("reply", "response", "answer", "text")
_TAG = re.compile(r"<\|?tool_call\|?>\s*(.*?)\s*(?:<\|?/tool_call\|?>|$)", re.DOTALL)
_FENCE = re.compile(r"```[ \t]*([A-Za-z_-]*)[ \t]*\n?(.*?)(?:```|$)", re.DOTALL)
_EMPTY_FENCE = re.compile(r"```[A-Za-z_-]*\s*```")
_CALL_MARKERS = re.compile(r"""["'](name|arguments|parameters|function|tool_call)["']\s*:""")


def _reject_constant(name: str) -> Any:
    raise ValueError(f"{name} is not a valid JSON number")


def parse_arguments(raw: Any) -> tuple[dict[str, Any] | None, str | None]:
    """(arguments, None) or (None, why not): a JSON object with finite numbers, or an error message."""
    if isinstance(raw, dict):
        return raw, None
    if raw is None or (isinstance(raw, str) and not raw.strip()):
        return {}, None
    if not isinstance(raw, str):
        return None, f"arguments must be a JSON object, got {type(raw).__name__}"
    try:
        value = json.loads(raw, parse_constant=_reject_constant)
    except ValueError as error:
        value, _ = load_json_like(raw)
        if not isinstance(value, dict):
            return None, f"arguments are not valid JSON ({error}): {raw[:200]!r}"
    if not isinstance(value, dict):
        return None, f"arguments must be a JSON object, got {type(value).__name__}: {raw[:200]!r}"
    return value, None


def format_hint(tool_names: Collection[str], structured: bool = False) -> str:
    """What a call must look like, with the tool names: the tail of every unreadable-call error."""
    no_call = ('{"reply": "<a short answer>"}' if structured else "plain text with no JSON")
    names = f"one of: {', '.join(sorted(tool_names))}" if tool_names else "a listed tool"
    return (
        'To call a tool, answer with one JSON object: {"name": "<tool>", "arguments": {...}} (no code fence), '
        f"where <tool> is {names}. To answer without calling a tool: {no_call}."
    )


def load_json_like(text: str) -> tuple[Any, str | None]:
    """(value, None) or (None, why not): JSON, tolerating doubled braces and Python literals."""
    stripped = text.strip()
    attempts = [stripped]
    if "{{" in stripped or "}}" in stripped:
        attempts.append(stripped.replace("{{", "{").replace("}}", "}"))
        if stripped.startswith("{{") and stripped.endswith("}}"):
            attempts.append(stripped[1:-1])
    first_error: str | None = None
    for attempt in attempts:
        try:
            return json.loads(attempt, parse_constant=_reject_constant), None
        except ValueError as error:
            first_error = first_error or str(error)
    for attempt in attempts:
        try:
            value = ast.literal_eval(attempt)
        except (ValueError, SyntaxError, TypeError, MemoryError, RecursionError):
            continue
        if isinstance(value, dict | list):
            try:  # only JSON-shaped literals (no tuples, sets, bytes), finite numbers
                return json.loads(json.dumps(value, allow_nan=False)), None
            except (TypeError, ValueError):
                continue
    return None, first_error


def _balanced_spans(text: str) -> list[tuple[int, int]]:
    """Spans of top-level ``{...}`` (and ``[{...}]``) in ``text``, strings respected; an unclosed one runs to
    the end."""
    spans: list[tuple[int, int]] = []
    i = 0
    while i < len(text):
        char = text[i]
        if char == "{" or (char == "[" and text[i + 1:].lstrip().startswith("{")):
            depth, j, quote = 0, i, None
            while j < len(text):
                c = text[j]
                if quote:
                    if c == "\\":
                        j += 1
                    elif c == quote:
                        quote = None
                elif c == '"':
                    quote = c
                elif c in "{[":
                    depth += 1
                elif c in "}]":
                    depth -= 1
                    if depth == 0:
                        break
                j += 1
            spans.append((i, min(j + 1, len(text))))
            i = j + 1
        else:
            i += 1
    return spans


class _Reader:
    """One answer's text to calls (see :func:`calls_from_text`)."""

    def __init__(self, tool_names: Collection[str], new_id: Callable[[], str], structured: bool) -> None:
        self.tools = set(tool_names)
        self.new_id = new_id
        self.structured = structured
        self.calls: list[ToolCall] = []
        self.replies: list[str] = []

    def fail(self, raw: str, why: str, name: str = UNPARSED) -> None:
        hint = format_hint(self.tools, self.structured)
        self.calls.append(ToolCall(self.new_id(), name, None, raw.strip()[:500], f"{why}. {hint}"))

    def call(self, name: str, raw_arguments: Any, raw: str) -> None:
        plausible = re.fullmatch(r"[\w.-]{1,64}", name) is not None
        if name not in self.tools and (self.tools or not plausible):  # no listed names: the agent checks it
            self.fail(raw, f"unknown tool {name!r}", name=name if plausible else UNPARSED)
            return
        arguments, error = parse_arguments(raw_arguments)
        if error is not None:
            self.calls.append(ToolCall(self.new_id(), name, None, raw.strip()[:500],
                                       f"{error}. {format_hint(self.tools, self.structured)}"))
            return
        self.calls.append(ToolCall(self.new_id(), name, arguments, json.dumps(arguments)))

    def item(self, item: Any, raw: str) -> bool:
        """Read one JSON value; False if it is neither a call nor a reply."""
        if isinstance(item, list):
            taken = [self.item(one, raw) for one in item]  # every item read, even after one that is not
            return bool(taken) and all(taken)
        if not isinstance(item, dict):
            return False
        for key in ("function", "tool_call", "function_call"):
            if isinstance(item.get(key), dict) and len(item) <= 3:
                return self.item(item[key], raw)
        if isinstance(item.get("tool_calls"), list):
            return self.item(item["tool_calls"], raw)
        name = next((item[k] for k in _NAME_KEYS if isinstance(item.get(k), str)), None)
        if name is not None:
            arguments = next((item[k] for k in _ARGUMENT_KEYS if k in item), None)
            self.call(name.strip(), arguments, raw)
            return True
        key = next((k for k in _REPLY_KEYS if isinstance(item.get(k), str)), None)
        if key is not None and set(item) <= {key, "cite"}:  # a reply, with the document it cites
            if self.structured and _BARE_CALL.fullmatch(item[key]):  # a call written as the reply's text
                before = len(self.calls)
                self.python_calls(item[key])
                if len(self.calls) > before:
                    return True
            cite = item.get("cite")
            cited = isinstance(cite, str) and cite.strip() and cite.strip() not in item[key]
            self.replies.append(f"{item[key]} [{cite.strip()}]" if cited else item[key])
            return True
        if len(item) == 1:
            ((key, value),) = item.items()
            if key in self.tools and isinstance(value, dict | str | type(None)):
                self.call(key, value, raw)
                return True
        return False

    def candidate(self, body: str, strong: bool) -> bool:
        """Read a JSON-ish snippet; True if it was taken (as calls, a reply or a failed call)."""
        value, error = load_json_like(body)
        looks_like_call = strong or bool(_CALL_MARKERS.search(body)) or any(t in body for t in self.tools)
        if error is not None:
            if looks_like_call:
                self.fail(body, f"could not read the tool call ({error})")
            return looks_like_call
        if self.item(value, body):
            return True
        if looks_like_call:
            self.fail(body, "a JSON answer that is not a tool call")
        return looks_like_call

    def python_calls(self, text: str) -> str:
        """Read ``tool(arg=value, ...)`` calls of listed tools; the text without them."""
        if not self.tools:
            return text
        names = "|".join(sorted(map(re.escape, self.tools), key=len, reverse=True))
        pattern = re.compile(rf"`?\b({names})\s*\(([^()]*)\)`?")
        for match in pattern.finditer(text):
            try:
                node = ast.parse(f"f({match.group(2)})", mode="eval").body
                assert isinstance(node, ast.Call) and not node.args
                arguments = {kw.arg: ast.literal_eval(kw.value) for kw in node.keywords if kw.arg}
                self.call(match.group(1), json.loads(json.dumps(arguments, allow_nan=False)), match.group(0))
            except (AssertionError, ValueError, SyntaxError, TypeError):
                self.fail(match.group(0), "could not read the arguments of this call", name=match.group(1))
        return pattern.sub("", text)


def calls_from_text(text: str, tool_names: Collection[str], new_id: Callable[[], str],
                    structured: bool = False) -> tuple[str, list[ToolCall]]:
    """(the text without the calls, the calls written in it): see the module docstring.

    ``structured``: the answer was asked for as JSON under the structured-mode schema (a ``{"reply": ...}``
    object's text is the reply; the error hint says to answer that way)."""
    reader = _Reader(tool_names, new_id, structured)
    spans: list[tuple[int, int]] = []
    for pattern in (_TAG, _FENCE):
        for match in pattern.finditer(text):
            if any(a <= match.start() < b for a, b in spans):
                continue
            body = match.group(match.lastindex or 1)
            if not body.strip() or (pattern is _FENCE and not body.lstrip().startswith(("{", "["))):
                continue  # a fence of prose or code (a Python-style call in it is read below)
            if reader.candidate(body, strong=True):
                spans.append(match.span())
    if not spans:
        whole = text.strip()
        for start, end in _balanced_spans(text):
            if reader.candidate(text[start:end], strong=text[start:end].strip() == whole):
                spans.append((start, end))
    rest = text
    for start, end in sorted(spans, reverse=True):
        rest = rest[:start] + rest[end:]
    if not reader.calls:
        rest = reader.python_calls(rest)
    rest = _EMPTY_FENCE.sub("", rest)
    if spans and not rest.strip(" \t\n{}[]`"):
        rest = ""  # the extra closing braces of an unbalanced doubled-brace call (Qwen writes `{{...}}}}`)
    rest = "\n".join(reader.replies + ([rest.strip()] if rest.strip() else []))
    return rest.strip(), reader.calls
