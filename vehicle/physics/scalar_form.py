"""The scalar form of a backend-generic core: its own source, compiled with ScalarOps inlined.

The cores (vehicle.physics, vehicle.control) are written once against a backend ``xp``
(NumpyOps for fleets of arrays, ScalarOps for a few vehicles on Python floats; see
vehicle.physics). On floats every ``xp.where`` / ``xp.clip`` / ``xp.minimum`` ... is a Python
call that costs more than the arithmetic it wraps, and a copter step makes some seventy of
them. ``@generic`` gives a core a scalar form: the function's syntax tree with

- ``xp.where(c, a, b)`` -> ``a if c else b``; ``xp.lnot(c)`` -> ``not c``; ``xp.any(c)`` and
  ``xp.all(c)`` -> ``True if c else False``;
- ``xp.clip(x, lo, hi)`` -> ``lo if x < lo else (hi if x > hi else x)``;
- ``xp.minimum(a, b)`` -> ``b if b < a else a`` and ``xp.maximum(a, b)`` -> ``b if b > a else a``
  (what the builtins min and max do with two arguments);
- any other ``xp.NAME`` -> ScalarOps.NAME itself (math.sqrt, ...), looked up once;
- a call of another ``@generic`` core -> a direct call of that core's scalar form;

each argument evaluated once (an assignment expression holds it where it is used twice),
comparisons as ScalarOps makes them, so NaN goes the same way. The scalar form therefore
computes exactly the numbers the core computes with ``xp=ScalarOps``, bit for bit (tests/
test_physics.py checks the rules one by one and tests/test_fleet.py whole flights); it only
skips evaluating the unused branch of a where, which has no effect on floats.

The decorated name dispatches: called with ``xp=ScalarOps`` (positionally or by keyword) it
runs the scalar form, else the core as written. ``core.scalar()`` returns the scalar form,
compiled on first use (by then every core it calls is defined), for callers that want to
skip the dispatch. Its globals are a copy of the module's taken then: the cores read only
constants, caches and modules from theirs.
"""
from __future__ import annotations

import ast
import copy
import functools
import inspect
import itertools
import textwrap
from collections.abc import Callable

from vehicle.physics import ScalarOps

_ONCE_FREE = (ast.Name, ast.Constant)       # reading these twice costs less than holding them


class _Inline(ast.NodeTransformer):
    """Rewrites the xp calls of one function (see the module docstring)."""

    def __init__(self, resolve: Callable[[ast.expr], str | None], bind: Callable[[str, object], str]) -> None:
        self.resolve = resolve          # call target -> name of its scalar form in the namespace, or None
        self.bind = bind                # (hint, object) -> a namespace name bound to object
        self.tmp = (f"_sf{i}" for i in itertools.count())

    def _once(self, e: ast.expr) -> tuple[ast.expr, Callable[[], ast.expr]]:
        """(first use, maker of a later use) of e, evaluated once. Every use is its own node
        (a node in two places of a tree would get its line numbers moved twice)."""
        if isinstance(e, _ONCE_FREE) or (isinstance(e, ast.UnaryOp) and isinstance(e.operand, _ONCE_FREE)):
            return e, lambda: copy.deepcopy(e)
        name = next(self.tmp)
        return ast.NamedExpr(target=ast.Name(name, ast.Store()), value=e), lambda: ast.Name(name, ast.Load())

    @staticmethod
    def _is_xp(node: ast.expr) -> bool:
        return isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) and node.value.id == "xp"

    def visit_Attribute(self, node: ast.Attribute) -> ast.expr:
        if self._is_xp(node):          # xp.atan2 handed on as a function, say
            return ast.Name(self.bind(node.attr, getattr(ScalarOps, node.attr)), ast.Load())
        return self.generic_visit(node)

    def visit_Call(self, node: ast.Call) -> ast.expr:
        func = node.func
        if self._is_xp(func) and not node.keywords:
            node.args = [self.visit(a) for a in node.args]
            out = self._inline(func.attr, node.args)
            if out is not None:
                return out
        elif not self._is_xp(func):
            target = self.resolve(func)
            if target is not None:
                node.func = ast.Name(target, ast.Load())
                node.args = [self.visit(a) for a in node.args]
                node.keywords = [self.visit(k) for k in node.keywords]
                return node
        return self.generic_visit(node)

    def _inline(self, op: str, a: list[ast.expr]) -> ast.expr | None:
        def cmp(left, how, right):
            return ast.Compare(left=left, ops=[how], comparators=[right])
        if op == "where" and len(a) == 3:
            return ast.IfExp(test=a[0], body=a[1], orelse=a[2])
        if op == "lnot" and len(a) == 1:
            return ast.UnaryOp(op=ast.Not(), operand=a[0])
        if op in ("any", "all") and len(a) == 1:
            return ast.IfExp(test=a[0], body=ast.Constant(True), orelse=ast.Constant(False))
        if op == "clip" and len(a) == 3:
            x1, x = self._once(a[0])
            lo1, lo = self._once(a[1])
            hi1, hi = self._once(a[2])
            return ast.IfExp(test=cmp(x1, ast.Lt(), lo1), body=lo(),
                             orelse=ast.IfExp(test=cmp(x(), ast.Gt(), hi1), body=hi(), orelse=x()))
        if op in ("minimum", "maximum") and len(a) == 2:
            b1, b = self._once(a[1])
            a1, a_ = self._once(a[0])
            return ast.IfExp(test=cmp(b1, ast.Lt() if op == "minimum" else ast.Gt(), a1), body=b(), orelse=a_())
        return None


def _compile(fn: Callable) -> Callable:
    """fn's scalar form (see the module docstring)."""
    tree = ast.parse(textwrap.dedent(inspect.getsource(fn)))
    fdef = tree.body[0]
    if not isinstance(fdef, ast.FunctionDef):
        raise TypeError(f"{fn.__qualname__}: not a plain function")
    fdef.decorator_list = []
    ns = dict(fn.__globals__)
    bound: dict[int, str] = {}

    def bind(hint: str, obj: object) -> str:
        name = bound.get(id(obj))
        if name is None:
            name = bound[id(obj)] = f"_sf_{hint}_{len(bound)}"
            ns[name] = obj
        return name

    def resolve(func: ast.expr) -> str | None:
        parts = []
        while isinstance(func, ast.Attribute):
            parts.append(func.attr)
            func = func.value
        if not isinstance(func, ast.Name) or func.id not in ns:
            return None
        obj = ns[func.id]
        for p in reversed(parts):
            obj = getattr(obj, p, None)
        scalar = getattr(obj, "scalar", None)
        if getattr(obj, "__wrapped__", None) is None or not callable(scalar):
            return None
        return bind(getattr(obj, "__name__", "core"), scalar())

    _Inline(resolve, bind).visit(tree)
    ast.fix_missing_locations(tree)
    ast.increment_lineno(tree, fn.__code__.co_firstlineno - 1)
    exec(compile(tree, inspect.getsourcefile(fn) or "<scalar form>", "exec"), ns)   # noqa: S102
    out = ns[fdef.name]
    out.__qualname__ = f"{fn.__qualname__} (scalar form)"
    return out


def generic(fn: Callable) -> Callable:
    """Decorate a core taking ``xp``: calls with xp=ScalarOps run its scalar form."""
    sig = inspect.signature(fn)
    at = list(sig.parameters).index("xp")
    default = sig.parameters["xp"].default
    form: list[Callable] = []

    def scalar() -> Callable:
        if not form:
            try:
                form.append(_compile(fn))
            except OSError:              # no source to read (a build without .py files):
                form.append(fn)          # the core itself, the same numbers, slower
        return form[0]

    @functools.wraps(fn)
    def dispatch(*args, **kwargs):
        xp = args[at] if len(args) > at else kwargs.get("xp", default)
        if xp is ScalarOps:
            return (form[0] if form else scalar())(*args, **kwargs)
        return fn(*args, **kwargs)
    dispatch.scalar = scalar
    return dispatch
