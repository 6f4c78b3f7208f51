"""The safe evaluator of xacro's ``${...}`` and ``$(eval ...)`` expressions (the default).

xacro itself evaluates expressions with Python's ``eval`` behind a filter of dunder names, which a
hostile file gets past (``python.vars(...)`` reaches a class's ``_module`` and from there ``os``),
so reading a ``.xacro`` vehicle could run any command. By default :mod:`aiauv_pin.description.xacro_loading`
hands every expression to :class:`SafeXacroEvaluator` instead: simpleeval's evaluator (it parses
with :mod:`ast` and evaluates the tree node by node, with a whitelist of node types, operators and
functions), narrowed further here to what a robot description needs:

* numbers, strings, ``True``/``False``, lists, tuples, dicts and sets written as literals;
* names of xacro properties (and macro parameters) and the constants ``pi``, ``e``, ``tau``,
  ``inf``, ``nan``;
* arithmetic ``+ - * / // % **``, comparisons, ``in``, ``and``/``or``/``not``, ``a if c else b``,
  indexing and slicing;
* calls of the whitelisted functions :data:`SAFE_FUNCTIONS` (trigonometry, ``sqrt``, ``radians``,
  ``abs``, ``min``, ``max``, ``round``, ``int``, ``float``, ``str``, ``len``, ``list``, ``dict``,
  ...), also written ``math.NAME``; ``NS.NAME`` reads property ``NAME`` of an include namespace.

Everything else is refused with :class:`UnsafeXacroExpression`: any other attribute access
(``python.vars``, ``x.__class__``, ``'a'.format``), any other call (``__import__``, ``open``,
``xacro.load_yaml``), lambdas, comprehensions, f-strings, ``%`` on strings, bitwise operators and
shifts. Sizes are bounded so that no expression runs for long or fills the memory: an expression
of at most :data:`MAX_EXPRESSION_CHARACTERS` characters, integers of at most
:data:`MAX_INTEGER_BITS` bits (``9**9**9`` is refused before it is computed), values of at most
:data:`MAX_VALUE_SIZE` items and characters counted through nested containers (``[[1]*n]*n`` is
refused before it is built), and :data:`MAX_TOTAL_SIZE` for all results of one expansion together.
"""

from __future__ import annotations

import ast
import math
import operator
from collections.abc import Callable, Mapping

from simpleeval import (
    EvalWithCompoundTypes,
    InvalidExpression,
    NameNotDefined,
    OperatorNotDefined,
)

from aiauv_pin.errors import VehicleLoadError

#: Longest expression evaluated [characters] (the longest in the UUV vehicles is about 600).
MAX_EXPRESSION_CHARACTERS = 10_000
#: Largest integer an expression may produce [bits] (a float ends at 2**1024).
MAX_INTEGER_BITS = 1024
#: Largest value an expression may produce [items + characters, counted through containers].
MAX_VALUE_SIZE = 100_000
#: Largest sum of the sizes of all expression results of one expansion (as the expanded text cap).
MAX_TOTAL_SIZE = 50_000_000

#: Constants a description may name besides its own properties.
SAFE_CONSTANTS = {"pi": math.pi, "e": math.e, "tau": math.tau, "inf": math.inf, "nan": math.nan}

_MATH_FUNCTIONS = (
    "sin cos tan asin acos atan atan2 sinh cosh tanh asinh acosh atanh sqrt exp log log10 log2 "
    "radians degrees floor ceil trunc fabs hypot copysign fmod isclose isfinite isinf isnan"
).split()


class UnsafeXacroExpression(VehicleLoadError):
    """A xacro expression the safe evaluator refuses (one line naming the file and expression)."""


def _number_sum(values, start=0):
    """``sum`` of numbers only (a sum of lists would build a list of unbounded size)."""
    values = list(values)
    if not all(isinstance(v, (int, float)) for v in [*values, start]):
        raise UnsafeXacroExpression("sum() takes numbers only")
    return sum(values, start)


#: Functions an expression may call, by name (and ``math.NAME`` for the math ones).
SAFE_FUNCTIONS: dict[str, Callable] = {
    **{name: getattr(math, name) for name in _MATH_FUNCTIONS},
    "abs": abs,
    "min": min,
    "max": max,
    "round": round,
    "int": int,
    "float": float,
    "str": str,
    "bool": bool,
    "len": len,
    "list": list,
    "tuple": tuple,
    "dict": dict,
    "sum": _number_sum,
}


def _short(value) -> str:
    """``value`` for a message: a number of up to 20 characters as is, a longer one abridged."""
    text = repr(value)
    return text if len(text) <= 20 else f"{text[:8]}...({len(text)} digits)"


def _size(value, memo: dict[int, tuple[object, int]]) -> int:
    """Items plus characters of ``value``, through nested containers, stopping past the cap.

    ``memo`` keeps each container measured before (and the container itself, so that its id is
    not reused), so that a value built from measured parts is measured in its own length.
    """
    if isinstance(value, bool) or value is None or isinstance(value, float):
        return 1
    if isinstance(value, int):
        if value.bit_length() > MAX_INTEGER_BITS:
            raise UnsafeXacroExpression(f"an integer of more than {MAX_INTEGER_BITS} bits")
        return 1
    if isinstance(value, str):
        return 1 + len(value)
    if not isinstance(value, (list, tuple, dict, set, frozenset)):
        return 1
    known = memo.get(id(value))
    if known is not None and known[0] is value:
        return known[1]
    total = 1
    items = value.items() if isinstance(value, dict) else value
    for item in items:
        total += _size(item, memo)
        if total > MAX_VALUE_SIZE:
            raise UnsafeXacroExpression(
                f"a value larger than {MAX_VALUE_SIZE} items and characters"
            )
    memo[id(value)] = (value, total)
    return total


class SafeXacroEvaluator(EvalWithCompoundTypes):
    """simpleeval's evaluator with xacro's names, only the constructs listed in the module doc.

    Args:
        namespace_type: xacro's ``NameSpace`` class (``NS.NAME`` reads a property of one).
    """

    def __init__(self, namespace_type: type):
        operators = {
            ast.Add: self._add,
            ast.Sub: operator.sub,
            ast.Mult: self._multiply,
            ast.Div: operator.truediv,
            ast.FloorDiv: operator.floordiv,
            ast.Mod: self._modulo,
            ast.Pow: self._power,
            ast.USub: operator.neg,
            ast.UAdd: operator.pos,
            ast.Not: operator.not_,
            ast.Eq: operator.eq,
            ast.NotEq: operator.ne,
            ast.Lt: operator.lt,
            ast.LtE: operator.le,
            ast.Gt: operator.gt,
            ast.GtE: operator.ge,
            ast.In: lambda a, b: a in b,
            ast.NotIn: lambda a, b: a not in b,
        }
        super().__init__(operators=operators, functions=dict(SAFE_FUNCTIONS), names={})
        self.functions = dict(SAFE_FUNCTIONS)  # the base class adds set(); keep the whitelist
        for refused in (
            ast.ListComp,
            ast.GeneratorExp,
            ast.DictComp,
            ast.Assign,
            ast.AugAssign,
            ast.Import,
            ast.JoinedStr,
            ast.FormattedValue,
        ):
            self.nodes.pop(refused, None)
        self._namespace_type = namespace_type
        self._memo: dict[int, tuple[object, int]] = {}
        self.total = 0

    # -- sizes ------------------------------------------------------------------------------------

    def _measure(self, value) -> int:
        return _size(value, self._memo)

    def _add(self, a, b):
        if isinstance(a, (str, list, tuple)) and isinstance(b, (str, list, tuple)):
            if self._measure(a) + self._measure(b) > MAX_VALUE_SIZE:
                raise UnsafeXacroExpression(
                    f"a value larger than {MAX_VALUE_SIZE} items and characters"
                )
        return a + b

    def _multiply(self, a, b):
        for sequence, count in ((a, b), (b, a)):
            if isinstance(sequence, (str, list, tuple)) and isinstance(count, int):
                if count > 0 and self._measure(sequence) * count > MAX_VALUE_SIZE:
                    raise UnsafeXacroExpression(
                        f"a value larger than {MAX_VALUE_SIZE} items and characters"
                    )
        return a * b

    @staticmethod
    def _modulo(a, b):
        if isinstance(a, (str, bytes)):
            raise UnsafeXacroExpression("'%' formatting of strings is not allowed")
        return a % b

    @staticmethod
    def _power(a, b):
        if isinstance(a, int) and isinstance(b, int) and b > 0 and abs(a) > 1:
            if b * math.log2(abs(a)) > MAX_INTEGER_BITS:
                raise UnsafeXacroExpression(
                    f"{_short(a)} ** {_short(b)} exceeds {MAX_INTEGER_BITS} bits (not a robot "
                    "dimension)"
                )
        try:
            return a**b
        except OverflowError:
            raise UnsafeXacroExpression(f"{_short(a)} ** {_short(b)} overflows") from None

    # -- the tree ---------------------------------------------------------------------------------

    def _eval(self, node):
        result = super()._eval(node)
        self._measure(result)
        return result

    def _eval_constant(self, node):
        value = super()._eval_constant(node)
        if not isinstance(value, (int, float, str, bool, type(None))):
            raise UnsafeXacroExpression(f"a {type(value).__name__} literal")
        return value

    def _eval_attribute(self, node):
        base = node.value
        if isinstance(base, ast.Name) and base.id == "math" and "math" not in self.names:
            if node.attr in SAFE_FUNCTIONS and node.attr in _MATH_FUNCTIONS:
                return SAFE_FUNCTIONS[node.attr]
            if node.attr in SAFE_CONSTANTS:
                return SAFE_CONSTANTS[node.attr]
            raise UnsafeXacroExpression(f"math.{node.attr} is not among the allowed functions")
        value = self._eval(base)
        if isinstance(value, self._namespace_type):  # <xacro:include ns="NS">: its properties
            try:
                return value[node.attr]
            except KeyError:
                raise UnsafeXacroExpression(f"no property '{node.attr}' in the namespace") from None
        raise UnsafeXacroExpression(f"attribute access ('.{node.attr}') is not allowed")

    def _eval_call(self, node):
        if isinstance(node.func, ast.Name):  # looked up among the whitelisted functions only
            if node.func.id not in self.functions:
                raise UnsafeXacroExpression(f"call of '{node.func.id}' is not allowed")
        elif isinstance(node.func, ast.Attribute) and isinstance(node.func.value, ast.Name):
            if not any(self._eval(node.func) is f for f in SAFE_FUNCTIONS.values()):
                raise UnsafeXacroExpression("call of a value that is not an allowed function")
        else:
            raise UnsafeXacroExpression("only calls of named functions are allowed")
        return super()._eval_call(node)

    def evaluate(self, expression: str, names: Mapping):
        """The value of ``expression`` with ``names`` (xacro's symbol table).

        Raises:
            UnsafeXacroExpression: A refused construct or a size beyond a limit (a reason only: the
                caller adds the file and the expression).
            Exception: Ordinary evaluation errors (``NameError``, ``ZeroDivisionError``, ...),
                which xacro reports as for its own evaluator.
        """
        text = expression.strip()
        if len(text) > MAX_EXPRESSION_CHARACTERS:
            raise UnsafeXacroExpression(
                f"an expression longer than {MAX_EXPRESSION_CHARACTERS} characters"
            )
        outer = self.names  # lazily evaluated properties evaluate inside an evaluation
        self.names = names
        try:
            result = self.eval(text)
        except RecursionError:
            raise UnsafeXacroExpression("an expression nested too deeply") from None
        except OperatorNotDefined as exc:
            name = type(exc.attr).__name__
            raise UnsafeXacroExpression(f"operator {name} is not allowed") from None
        except NameNotDefined as exc:
            raise NameError(f"name '{exc.name}' is not defined") from None
        except InvalidExpression as exc:  # simpleeval's other refusals
            raise UnsafeXacroExpression(" ".join(str(exc).split())) from None
        finally:
            self.names = outer
        self.total += self._measure(result)
        if self.total > MAX_TOTAL_SIZE:
            raise UnsafeXacroExpression(
                f"the expressions' results together exceed {MAX_TOTAL_SIZE} characters"
            )
        return result
