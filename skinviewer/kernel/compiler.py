"""The render graph's compiler (Filament's FrameGraph ``compile``): from every pass's reflection, the
order passes run in (producers before consumers, from the targets back), the passes nobody consumes
(pruned, and why), why a pass's cache key changed, and which passes an edit would re-run. Pure
functions of reflections: no GL."""
from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from skinviewer.kernel.pass_api import GraphError, Pass, Reflection


def order_passes(passes: list[Pass], refl: dict[str, Reflection], targets: list[str]) -> tuple[list[Pass], set[str]]:
    """The passes the targets need, producers first, and their names (the live set); raises
    GraphError on a resource written twice, read but never written, a cycle, or an unknown target."""
    producer: dict[str, Pass] = {}
    for p in passes:
        for out in refl[p.name].outputs:
            if out in producer:
                raise GraphError(f"'{out}' is written by both {producer[out].name} and {p.name}")
            producer[out] = p
    live: set[str] = set()
    order: list[Pass] = []
    state: dict[str, int] = {}

    def visit(p: Pass, chain: tuple[str, ...]) -> None:
        s = state.get(p.name, 0)
        if s == 2:
            return
        if s == 1:
            raise GraphError(f"cycle in the pass graph: {' -> '.join(chain + (p.name,))}")
        state[p.name] = 1
        for res in refl[p.name].inputs:
            if res not in producer:
                raise GraphError(f"pass {p.name} reads '{res}', which no pass writes")
            visit(producer[res], chain + (p.name,))
        state[p.name] = 2
        live.add(p.name)
        order.append(p)

    for t in targets:
        if t not in producer:
            raise GraphError(f"target '{t}' is written by no pass (have: {sorted(producer)})")
        visit(producer[t], ())
    return order, live


def why(old: dict[str, Any] | None, new: dict[str, Any]) -> str:
    """What changed between a pass's last cache key and this frame's ("first run" without one)."""
    if old is None:
        return "first run"
    parts = []
    for group in ("scene", "camera"):
        if old.get(group) != new.get(group):
            parts.append(group)
    for group, label in (("settings", "setting"), ("inputs", "input"), ("programs", "shader"),
                         ("outputs", "output"), ("plan", "plan")):
        o, n = old.get(group, {}), new.get(group, {})
        changed = [k for k in n if o.get(k) != n[k]] + [k for k in o if k not in n]
        parts += [f"{label} {k}" for k in changed]
    return ", ".join(parts)


def prune_reason(name: str, refl: dict[str, Reflection], live: set[str], depth: int = 0) -> str:
    """Why a pass is pruned: its own skip reason, a consumer's reason for dropping its output, or
    the reason its only consumers are pruned."""
    r = refl[name]
    if r.skip_reason is not None:
        return "pruned: " + r.skip_reason
    outs = set(r.outputs)
    for other in refl.values():
        for res in outs & set(other.dropped):
            return "pruned: " + other.dropped[res]
    if depth < 8:
        for n, other in refl.items():
            if n not in live and n != name and outs & set(other.inputs):
                reason = prune_reason(n, refl, live, depth + 1)
                if reason.startswith("pruned: "):
                    return reason if "(via " in reason else reason + f" (via {n})"
    return "output not consumed"


def pixels(r: Reflection) -> int:
    """The pixels of a pass's largest output (what its cost follows, to first order)."""
    return max((int(spec.size[0]) * int(spec.size[1]) for spec in r.outputs.values()), default=0)


def affected(order: list[Pass], refl: dict[str, Reflection], paths: Iterable[str], camera: bool = False) -> list[str]:
    """Passes (in ``order``) that a change of these settings would re-run: those that declared a path
    equal to, inside or around one of ``paths``, those that are view-dependent when ``camera``, and
    everything downstream of them."""
    paths = list(paths)

    def touches(declared: str) -> bool:
        return any(d == p or d.startswith(p + ".") or p.startswith(d + ".")
                   for p in paths for d in (declared.replace(".#", ""),))

    dirty: set[str] = set()
    for p in order:
        r = refl.get(p.name)
        if r is None:
            continue
        if (camera and p.view_dependent) or any(touches(d) for d in r.declared) \
                or any(res in dirty for res in r.inputs):
            dirty.update(r.outputs)
            dirty.add("pass:" + p.name)
    return [p.name for p in order if "pass:" + p.name in dirty]
