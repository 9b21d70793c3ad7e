"""A control specification: an immutable set of attached primitives, and the slot that swaps it atomically.

The controller reads one :class:`Specification` snapshot per control step; the agent (another thread)
builds a new one and swaps it into the :class:`SpecificationSlot`. Because specifications are immutable
and the swap happens under a lock, a control step never sees half of a change.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from agentic_mpc.primitives.base import (
    FloatArray,
    FusedArrays,
    FusedTerms,
    PreparedCost,
    Primitive,
    Rollouts,
    StepContext,
)
from agentic_mpc.primitives.mandatory import Mandatory
from agentic_mpc.primitives.path_tracking import PathTracking


class SpecificationError(ValueError):
    """A change the specification refuses: detaching the mandatory part, or an unknown primitive."""


@dataclass(frozen=True, slots=True)
class Specification:
    """The attached primitives, the mandatory one first. Build with :meth:`of`; change with attach/detach."""

    primitives: tuple[Primitive, ...]

    @classmethod
    def of(cls, *primitives: Primitive, mandatory: Mandatory | None = None) -> Specification:
        """A specification with ``mandatory`` (default J0 if none is given among ``primitives``) and the rest."""
        given = [p for p in primitives if not p.mandatory]
        given_mandatory = [p for p in primitives if p.mandatory]
        if len(given_mandatory) > 1 or (given_mandatory and mandatory is not None):
            raise SpecificationError("a specification has exactly one mandatory primitive")
        j0 = mandatory or (given_mandatory[0] if given_mandatory else Mandatory())
        return cls((j0,)).attach(*given)

    def __post_init__(self) -> None:
        if not self.primitives or not self.primitives[0].mandatory:
            raise SpecificationError("the first primitive of a specification must be the mandatory one")
        names = [p.name for p in self.primitives]
        if len(set(names)) != len(names):
            raise SpecificationError(f"duplicate primitive names in {names}")

    @property
    def mandatory(self) -> Mandatory:
        return self.primitives[0]  # type: ignore[return-value]

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.primitives)

    def get(self, name: str) -> Primitive | None:
        return next((p for p in self.primitives if p.name == name), None)

    def __contains__(self, name: object) -> bool:
        return any(p.name == name for p in self.primitives)

    def attach(self, *primitives: Primitive) -> Specification:
        """A new specification with ``primitives`` attached; one with the same name is replaced in place."""
        result = list(self.primitives)
        for primitive in primitives:
            if primitive.mandatory:
                result[0] = primitive
                continue
            names = [p.name for p in result]
            if primitive.name in names:
                result[names.index(primitive.name)] = primitive
            else:
                result.append(primitive)
        return Specification(tuple(result))

    def detach(self, *names: str) -> Specification:
        """A new specification without ``names``. The mandatory part cannot be detached."""
        for name in names:
            primitive = self.get(name)
            if primitive is None:
                raise SpecificationError(f"cannot detach {name!r}: not attached (attached: {list(self.names)})")
            if primitive.mandatory:
                raise SpecificationError(f"cannot detach {name!r}: the mandatory objective J0 is always attached")
        return Specification(tuple(p for p in self.primitives if p.name not in names))

    def describe(self) -> list[dict[str, Any]]:
        return [p.describe() for p in self.primitives]

    @property
    def asks_for_motion(self) -> bool:
        """Whether some attached primitive wants the car to move (path tracking with v_ref > 0)."""
        return any(isinstance(p, PathTracking) and p.v_ref_mps > 0.0 for p in self.primitives)

    def summary(self) -> str:
        """A compact one-line form for logs and CSV columns."""
        return "; ".join(p.summary() for p in self.primitives[1:]) or "(mandatory only)"

    def prepare(self, context: StepContext) -> PreparedSpecification:
        """Bind every primitive to this step; path tracking first, so others can read its reference."""
        order = sorted(self.primitives, key=lambda p: not isinstance(p, PathTracking))
        prepared: list[PreparedCost] = []
        for primitive in order:
            bound = primitive.prepare(context)
            if isinstance(primitive, PathTracking) and context.tracking_reference is None:
                context = _with_reference(context, bound.reference)  # type: ignore[attr-defined]
            prepared.append(bound)
        return PreparedSpecification(tuple(prepared), context.horizon)


def _with_reference(context: StepContext, reference: Any) -> StepContext:
    return StepContext(
        context.state, context.horizon, context.params, context.surroundings, reference, context.previous_input
    )


@dataclass(frozen=True, slots=True)
class PreparedSpecification:
    costs: tuple[PreparedCost, ...]
    horizon: int

    def cost(self, rollouts: Rollouts) -> FloatArray:
        """Total cost of every sample (NumPy reference)."""
        total = self.costs[0].cost(rollouts)
        for prepared in self.costs[1:]:
            total = total + prepared.cost(rollouts)
        return total

    def fused_arrays(self) -> FusedArrays | None:
        """The fused kernel's arrays, or None if some primitive has no fused form."""
        terms = FusedTerms(self.horizon)
        if all(prepared.add_fused_terms(terms) for prepared in self.costs):
            return terms.build()
        return None


@dataclass(eq=False)
class SpecificationSlot:
    """Holds the current specification; swaps are atomic and serialised, reads are lock-free snapshots."""

    initial: Specification
    _current: Specification = field(init=False)
    _version: int = field(default=0, init=False)
    _lock: threading.Lock = field(default_factory=threading.Lock, init=False)
    _listeners: list[Callable[[Specification, int], None]] = field(default_factory=list, init=False)

    def __post_init__(self) -> None:
        self._current = self.initial

    @property
    def current(self) -> Specification:
        return self._current

    @property
    def version(self) -> int:
        """Incremented by every swap."""
        return self._version

    def snapshot(self) -> tuple[Specification, int]:
        with self._lock:
            return self._current, self._version

    def update(self, change: Callable[[Specification], Specification]) -> Specification:
        """Apply ``change`` to the current specification and swap the result in, atomically.

        If ``change`` raises, nothing is swapped and the error propagates.
        """
        with self._lock:
            new = change(self._current)
            if not isinstance(new, Specification):
                raise TypeError(f"a specification change must return a Specification, got {type(new).__name__}")
            self._current = new
            self._version += 1
            version = self._version
        for listener in list(self._listeners):
            listener(new, version)
        return new

    def replace(self, specification: Specification) -> Specification:
        return self.update(lambda _: specification)

    def subscribe(self, listener: Callable[[Specification, int], None]) -> None:
        """Call ``listener(spec, version)`` after every swap (from the swapping thread)."""
        self._listeners.append(listener)


