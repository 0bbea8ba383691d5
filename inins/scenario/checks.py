"""Pass/fail checks on a command's results, evaluated safely.

A check is one expression from the scenario's ``checks:`` list::

    abs(err.beta_x_dph) < 0.002
    -0.01 < beta_y_dph < 0
    truth.beta_x_dph > 0 and method_valid

Names
    ``NAME`` is the result ``NAME``; ``truth.NAME`` the truth value;
    ``err.NAME`` is result minus truth.
Allowed
    numbers, ``true``/``false`` (``True``/``False``), comparisons (chained too),
    ``and``/``or``/``not``, ``+ - * / **``, unary ``-``/``+``, and calls to
    ``abs``, ``min``, ``max``, ``sqrt``. Nothing else: the expression is parsed
    with :mod:`ast` and walked node by node, never passed to ``eval``.

A name no result or truth carries, or an expression outside this grammar, is
bad input (:class:`~inins.exceptions.InputError` naming ``checks[i]``). A value
that is None or NaN (a method not applicable), a missing truth, or an
arithmetic error (division by zero) makes the check fail with a ``reason``.
"""

import ast
import math
import operator

from inins.exceptions import InputError

_FUNCS = {"abs": abs, "min": min, "max": max, "sqrt": math.sqrt}
_BINOPS = {
    ast.Add: operator.add,
    ast.Sub: operator.sub,
    ast.Mult: operator.mul,
    ast.Div: operator.truediv,
    ast.Pow: operator.pow,
}
_CMPOPS = {
    ast.Lt: operator.lt,
    ast.LtE: operator.le,
    ast.Gt: operator.gt,
    ast.GtE: operator.ge,
    ast.Eq: operator.eq,
    ast.NotEq: operator.ne,
}
_NAMESPACES = ("err", "truth")
_MAX_LENGTH = 1000


class CheckSyntaxError(ValueError):
    """A check expression outside the allowed grammar."""


class _NotApplicable(Exception):
    """A value the check needs is None, NaN or missing: the check fails."""


def parse_check(expr: str) -> ast.Expression:
    """Parse and validate one check expression.

    Parameters
    ----------
    expr : str

    Returns
    -------
    ast.Expression

    Raises
    ------
    CheckSyntaxError
        Not an expression, or uses something outside the allowed grammar.
    """
    if not isinstance(expr, str) or not expr.strip():
        raise CheckSyntaxError("empty check; expected an expression such as 'abs(x_dph) < 0.1'")
    if len(expr) > _MAX_LENGTH:
        raise CheckSyntaxError(f"check longer than {_MAX_LENGTH} characters")
    try:
        tree = ast.parse(expr.strip(), mode="eval")
    except SyntaxError as exc:
        raise CheckSyntaxError(f"invalid expression: {exc.msg} in {expr!r}") from None
    _validate(tree.body, expr)
    if not _is_condition(tree.body):
        raise CheckSyntaxError(
            f"a check must be a comparison or a true/false value (e.g. 'x_dph < 0.1'), got {expr!r}"
        )
    return tree


def _is_condition(node) -> bool:
    """True for nodes that can give true/false: comparisons, and/or/not, names."""
    if isinstance(node, ast.Constant):
        return isinstance(node.value, bool)
    if isinstance(node, ast.UnaryOp):
        return isinstance(node.op, ast.Not)
    return isinstance(node, ast.Compare | ast.BoolOp | ast.Name | ast.Attribute)


def _validate(node, expr) -> None:
    """Walk the tree and reject every node type not in the grammar."""
    if isinstance(node, ast.Constant):
        if isinstance(node.value, bool | int | float):
            return
        raise CheckSyntaxError(f"only numbers are allowed as constants, got {node.value!r}")
    if isinstance(node, ast.Name):
        if node.id in _NAMESPACES or node.id in _FUNCS:
            raise CheckSyntaxError(f"{node.id!r} cannot be used on its own in {expr!r}")
        return
    if isinstance(node, ast.Attribute):
        if not (isinstance(node.value, ast.Name) and node.value.id in _NAMESPACES):
            raise CheckSyntaxError(f"only err.NAME and truth.NAME may use a dot, in {expr!r}")
        return
    children = _children(node, expr)
    for child in children:
        _validate(child, expr)


def _children(node, expr) -> list:
    """Sub-expressions of an allowed composite node."""
    if isinstance(node, ast.BoolOp):
        return list(node.values)
    if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.Not | ast.USub | ast.UAdd):
        return [node.operand]
    if isinstance(node, ast.BinOp) and type(node.op) in _BINOPS:
        return [node.left, node.right]
    if isinstance(node, ast.Compare) and all(type(op) in _CMPOPS for op in node.ops):
        return [node.left, *node.comparators]
    if isinstance(node, ast.Call):
        if not (isinstance(node.func, ast.Name) and node.func.id in _FUNCS):
            raise CheckSyntaxError(f"only abs, min, max and sqrt may be called, in {expr!r}")
        name, nargs = node.func.id, len(node.args)
        wrong = nargs != 1 if name in ("abs", "sqrt") else nargs < 2
        if node.keywords or any(isinstance(a, ast.Starred) for a in node.args) or wrong:
            count = "one argument" if name in ("abs", "sqrt") else "two or more arguments"
            raise CheckSyntaxError(f"{name}() takes {count}, in {expr!r}")
        return list(node.args)
    raise CheckSyntaxError(f"{ast.unparse(node)!r} is not allowed in a check")


def evaluate_checks(checks, results: dict, truth: dict) -> list[dict]:
    """Evaluate the scenario's checks against a command's results.

    Parameters
    ----------
    checks : sequence of str
        Expressions, in scenario order.
    results, truth : dict
        Flat name -> number (or None where not applicable).

    Returns
    -------
    list of dict
        One ``{"name": expr, "passed": bool, "value": float or None}`` per
        check, plus ``"reason"`` when it failed for want of a value. ``value``
        is the first non-constant operand of a top-level comparison (the
        quantity being checked), or the value of a bare name.

    Raises
    ------
    InputError
        A syntax error, an unknown name, or a check that is not true/false
        (``key`` is ``checks[i]``).
    """
    out = []
    for i, expr in enumerate(checks):
        key = f"checks[{i}]"
        try:
            tree = parse_check(expr)
        except CheckSyntaxError as exc:
            raise InputError(str(exc), key=key) from None
        _check_names(tree, results, truth, key)
        out.append(_evaluate_one(expr, tree.body, results, truth, key))
    return out


def validate_names(checks, results, truth) -> None:
    """Check, before a run, that every name in ``checks`` is one the command declares.

    Parameters
    ----------
    checks : sequence of str
    results, truth : collection of str
        Names the command's results (and truth) may carry.

    Raises
    ------
    InputError
        A syntax error or an unknown name (``key`` is ``checks[i]``).
    """
    for i, expr in enumerate(checks):
        key = f"checks[{i}]"
        try:
            tree = parse_check(expr)
        except CheckSyntaxError as exc:
            raise InputError(str(exc), key=key) from None
        _check_names(tree, frozenset(results), frozenset(truth), key)


def _check_names(tree, results, truth, key) -> None:
    known = set(results) | set(truth)
    bases = {id(n.value) for n in ast.walk(tree) if isinstance(n, ast.Attribute)}
    bases |= {id(n.func) for n in ast.walk(tree) if isinstance(n, ast.Call)}
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute):
            name, ns = node.attr, node.value.id
        elif isinstance(node, ast.Name) and id(node) not in bases:
            name, ns = node.id, None
        else:
            continue
        if name in (results if ns is None else known):
            continue
        raise InputError(_unknown_message(name, ns, results, truth), key=key)


def _unknown_message(name, ns, results, truth) -> str:
    import difflib

    pool = sorted(results if ns is None else set(results) | set(truth))
    label = name if ns is None else f"{ns}.{name}"
    hint = difflib.get_close_matches(name, pool, n=1)
    said = f"; did you mean {hint[0]!r}?" if hint else ""
    shown = ", ".join(pool[:20]) + (", ..." if len(pool) > 20 else "")
    return f"unknown name {label!r} in a check{said} (results: {shown or 'none'})"


def _evaluate_one(expr, body, results, truth, key) -> dict:
    entry: dict = {"name": expr, "passed": False, "value": None}
    env = _Env(results, truth)
    try:
        entry["value"] = _subject_value(body, env)
        outcome = _eval(body, env)
    except _NotApplicable as exc:
        entry["reason"] = str(exc)
        return entry
    except OverflowError:
        entry["reason"] = "cannot evaluate: number too large"
        return entry
    except (ArithmeticError, ValueError) as exc:
        entry["reason"] = f"cannot evaluate: {exc}"
        return entry
    if not isinstance(outcome, bool):
        raise InputError(f"a check must be true or false, {expr!r} gives {outcome!r}", key=key)
    entry["passed"] = outcome
    return entry


def _subject_value(body, env) -> float | bool | None:
    """The quantity a check tests: first non-constant operand, or a bare name."""
    if isinstance(body, ast.Compare):
        for node in (body.left, *body.comparators):
            if not _is_constant(node):
                return _plain(_eval(node, env))
        return None
    if isinstance(body, ast.Name | ast.Attribute):
        return _plain(_eval(body, env))
    return None


def _is_constant(node) -> bool:
    """True if a sub-expression names no result (``-0.01``, ``2 * 0.5``)."""
    return not any(isinstance(n, ast.Name | ast.Attribute) for n in ast.walk(node))


def _plain(value):
    """A JSON-ready value: bool stays bool, numbers become float."""
    if isinstance(value, bool):
        return value
    return float(value) if isinstance(value, int | float) else None


class _Env:
    """Name lookup for the evaluator."""

    def __init__(self, results, truth):
        self.results, self.truth = results, truth

    def get(self, ns, name):
        if ns is None:
            return _usable(self.results[name], name)
        if ns == "truth":
            return _usable(self.truth.get(name), f"truth.{name}", missing=name not in self.truth)
        measured = _usable(self.results.get(name), name)
        true = _usable(self.truth.get(name), f"truth.{name}", missing=name not in self.truth)
        return measured - true


def _usable(value, label, missing=False):
    if missing:
        raise _NotApplicable(f"no truth value for {label.removeprefix('truth.')}")
    if value is None:
        raise _NotApplicable(f"{label} is not available (method not applicable)")
    if hasattr(value, "item") and not isinstance(value, bool | int | float):
        value = value.item()  # numpy scalars -> Python
    if not isinstance(value, bool | int | float):
        raise _NotApplicable(f"{label} is not a number ({type(value).__name__})")
    if isinstance(value, float) and math.isnan(value):
        raise _NotApplicable(f"{label} is NaN")
    return value


def _eval(node, env):
    """Evaluate a validated node; integers become floats (no huge int powers)."""
    if isinstance(node, ast.Constant):
        return node.value if isinstance(node.value, bool) else float(node.value)
    if isinstance(node, ast.Name):
        return env.get(None, node.id)
    if isinstance(node, ast.Attribute):
        return env.get(node.value.id, node.attr)
    if isinstance(node, ast.BoolOp):
        if isinstance(node.op, ast.And):
            return all(bool(_eval(v, env)) for v in node.values)
        return any(bool(_eval(v, env)) for v in node.values)
    if isinstance(node, ast.UnaryOp):
        value = _eval(node.operand, env)
        if isinstance(node.op, ast.Not):
            return not value
        return -value if isinstance(node.op, ast.USub) else +value
    if isinstance(node, ast.BinOp):
        return _BINOPS[type(node.op)](float(_eval(node.left, env)), float(_eval(node.right, env)))
    if isinstance(node, ast.Compare):
        left = _eval(node.left, env)
        for op, right_node in zip(node.ops, node.comparators, strict=True):
            right = _eval(right_node, env)
            if not _CMPOPS[type(op)](left, right):
                return False
            left = right
        return True
    args = [_eval(a, env) for a in node.args]
    return _FUNCS[node.func.id](*args)
