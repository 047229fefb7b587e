"""The implicit-function language users type: parse once, then evaluate with numpy or emit GLSL.

Grammar (whitelist; nothing else is accepted):

    expr    := term (("+" | "-") term)*
    term    := unary (("*" | "/") unary)*
    unary   := ("-" | "+") unary | power
    power   := atom ("^" unary)?          # right-associative: 2^3^2 = 2^9; -x^2 = -(x^2)
    atom    := NUMBER | "x" | "y" | "z" | "pi" | FUNC "(" expr ("," expr)* ")" | "(" expr ")"
    FUNC    := sin cos tan exp log sqrt abs (one argument) | min max (two)

Both back ends compute in float32 with the same IEEE semantics, spelled out
rather than left to the GL driver: log(-1) and sqrt(-1) are NaN, 1/0 is Inf,
0*Inf is NaN, a negative base to a fractional power is NaN, pow follows C99,
min/max propagate NaN and order -0 below +0, and every result below the
smallest normal float is flushed to a zero of its sign (GPUs flush denormals,
their exp/pow never make them).  So the samples agree element for element,
non-finite ones included, and the finite-values check after sampling accepts
or refuses a formula alike on CPU and GPU.

Nothing recurses with the size of a formula: chains such as x+x+...+x parse in
a loop, evaluation and GLSL emission walk the tree with an explicit stack (GLSL
gets one statement per operation, never deep parentheses), and nesting
(parentheses, function arguments, exponents) is bounded by MAX_DEPTH.
The user's text reaches GLSL only as the emitter's output: numbers are
re-printed from floats, names come from the whitelist tables below.
"""
from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from .errors import VolumeError

VARIABLES = ("x", "y", "z")
CONSTANTS = {"pi": math.pi}
FUNCTIONS = {"sin": 1, "cos": 1, "tan": 1, "exp": 1, "log": 1, "sqrt": 1, "abs": 1, "min": 2, "max": 2}
MAX_LENGTH = 2000  # far beyond any formula a person types
# Nesting levels: parentheses, function arguments and exponents (2^2^...). The parser
# recurses about 9 Python frames per level; 50 levels stay far below the recursion limit.
MAX_DEPTH = 50
FLOAT32_MAX = float(np.finfo(np.float32).max)
FLOAT32_TINY = float(np.finfo(np.float32).tiny)  # the smallest normal float32

_TOKEN = re.compile(r"""
    (?P<number>(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)
  | (?P<name>[A-Za-z_][A-Za-z_0-9]*)
  | (?P<op>[-+*/^(),])
  | (?P<space>\s+)
""", re.VERBOSE)


# --- the syntax tree ---------------------------------------------------------------------

@dataclass(frozen=True)
class Number:
    """A number in a parsed formula."""
    value: float


@dataclass(frozen=True)
class Variable:
    """A coordinate in a parsed formula: x, y or z."""
    name: str  # "x", "y" or "z"


@dataclass(frozen=True, eq=False, repr=False)  # no recursive ==, hash or repr on deep trees
class Unary:
    """A negated operand in a parsed formula."""
    op: str  # "-" (a unary "+" is dropped by the parser)
    operand: object


@dataclass(frozen=True, eq=False, repr=False)  # no recursive ==, hash or repr on deep trees
class Binary:
    """An arithmetic operation of two operands in a parsed formula: + - * / or ^."""
    op: str  # + - * / ^
    left: object
    right: object


@dataclass(frozen=True, eq=False, repr=False)  # no recursive ==, hash or repr on deep trees
class Call:
    """A call of one of the language's functions in a parsed formula."""
    function: str
    args: tuple


@dataclass(frozen=True)
class Token:
    """One token of a formula: its kind (number, name, op or end), its text and its column (1-based, for messages)."""
    kind: str  # number, name, op, end
    text: str
    column: int  # 1-based, for messages


def _error(text: str, column: int, problem: str, fix: str) -> VolumeError:
    # Quote the neighbourhood of a long formula so the message stays one readable line.
    start = max(0, column - 30)
    excerpt = ("..." if start else "") + text[start:column + 30] + ("..." if column + 30 < len(text) else "")
    return VolumeError(f"expression error at column {column}: {problem} in \"{excerpt}\"; {fix}")


def tokenize(text: str) -> list[Token]:
    """The formula's tokens, ending with an "end" token; a character the language does not have is a refusal naming its
    column."""
    tokens, position = [], 0
    while position < len(text):
        match = _TOKEN.match(text, position)
        if match is None:
            raise _error(text, position + 1, f"unexpected character {text[position]!r}",
                         "use numbers, x y z, + - * / ^, parentheses and the listed functions")
        if match.lastgroup != "space":
            tokens.append(Token(match.lastgroup, match.group(), position + 1))
        position = match.end()
    tokens.append(Token("end", "", len(text) + 1))
    return tokens


class _Parser:
    def __init__(self, text: str):
        self.text = text
        self.tokens = tokenize(text)
        self.index = 0
        self.depth = 0

    @property
    def token(self) -> Token:
        """The token being read."""
        return self.tokens[self.index]

    def take(self) -> Token:
        """The token being read, moving past it."""
        token = self.token
        self.index += 1
        return token

    def fail(self, token: Token, problem: str, fix: str):
        """Raise the formula's refusal at `token`'s column: `problem`, then `fix`."""
        raise _error(self.text, token.column, problem, fix)

    def expect(self, op: str) -> None:
        """Move past the operator `op`; a refusal naming what stands there instead."""
        if self.token.text != op or self.token.kind != "op":
            found = "the end" if self.token.kind == "end" else f"{self.token.text!r}"
            self.fail(self.token, f"expected {op!r} but found {found}", f"add the missing {op!r}")
        self.take()

    def parse(self):
        """The whole formula's tree; an empty formula, or anything left after it (a missing operator, a stray ')'), is
        refused."""
        if self.token.kind == "end":
            self.fail(self.token, "the expression is empty", "type a formula such as x^2 + y^2 + z^2 - 1")
        tree = self.expr()
        if self.token.kind != "end":
            token = self.token
            if token.kind in ("number", "name") or token.text == "(":
                self.fail(token, f"missing operator before {token.text!r}",
                          "write multiplication explicitly, e.g. 2*x")
            self.fail(token, f"unexpected {token.text!r}", "check the parentheses and operators")
        return tree

    def expr(self):
        """expr := term (("+" | "-") term)*"""
        return self.left_associative(("+", "-"), self.term)

    def term(self):
        """term := unary (("*" | "/") unary)*"""
        return self.left_associative(("*", "/"), self.unary)

    def left_associative(self, ops: tuple[str, ...], operand):
        """`operand`s joined by any of `ops`, grouped from the left: a - b - c is (a - b) - c."""
        node = operand()
        while self.token.kind == "op" and self.token.text in ops:
            op = self.take().text
            node = Binary(op, node, operand())
        return node

    def unary(self):
        """unary := ("-" | "+")* power"""
        # A run of signs is read in a loop: "----x" is x, at any length (-(-v) is v bit for bit).
        negative = False
        while self.token.kind == "op" and self.token.text in ("-", "+"):
            negative ^= self.take().text == "-"
        operand = self.power()
        return Unary("-", operand) if negative else operand

    def power(self):
        """power := atom ("^" unary)?, right-associative through the unary: 2^-x and 2^3^2 = 2^(3^2)."""
        base = self.atom()
        if self.token.kind == "op" and self.token.text == "^":
            self.take()
            return Binary("^", base, self.nested(self.unary))
        return base

    def nested(self, rule):
        """`rule` one level deeper; past `MAX_DEPTH` levels a refusal, never a RecursionError."""
        # Recursion depth is bounded so "((((..." gives a message, not a RecursionError.
        self.depth += 1
        if self.depth > MAX_DEPTH:
            self.fail(self.token, f"the expression nests more than {MAX_DEPTH} levels deep "
                      f"(parentheses, function calls, exponents)", f"use at most {MAX_DEPTH} levels")
        try:
            return rule()
        finally:
            self.depth -= 1

    def atom(self):
        """atom := number | name | "(" expr ")"; a number past float32's range, or anything else here, is refused."""
        token = self.take()
        if token.kind == "number":
            value = float(token.text)
            if not math.isfinite(value) or abs(value) > FLOAT32_MAX:
                self.fail(token, f"number {token.text} is too large for 32-bit floats", "use a smaller number")
            return Number(value)
        if token.kind == "name":
            return self.name(token)
        if token.text == "(":
            node = self.nested(self.expr)
            self.expect(")")
            return node
        found = "the end of the expression" if token.kind == "end" else repr(token.text)
        self.fail(token, f"expected a number, x, y, z, a function or '(' but found {found}",
                  "complete the formula")

    def name(self, token: Token):
        """A variable, a constant or a function call for the name `token`; an unknown name is refused with the names
        there are."""
        name = token.text
        if name in VARIABLES:
            return Variable(name)
        if name in CONSTANTS:
            return Number(CONSTANTS[name])
        if name not in FUNCTIONS:
            self.fail(token, f"unknown name {name!r}",
                      f"use x y z pi or {' '.join(FUNCTIONS)}")
        if self.token.text != "(":
            self.fail(self.token, f"{name} needs parentheses", f"write {name}(...)")
        self.take()
        args = [self.nested(self.expr)]
        while self.token.text == "," and self.token.kind == "op":
            self.take()
            args.append(self.nested(self.expr))
        if len(args) != FUNCTIONS[name]:
            self.fail(token, f"{name} takes {FUNCTIONS[name]} argument(s), got {len(args)}",
                      f"give {name} {FUNCTIONS[name]} argument(s)")
        self.expect(")")
        return Call(name, tuple(args))


def parse(text: str):
    """The syntax tree of a formula, or a VolumeError pointing at the column."""
    if len(text) > MAX_LENGTH:
        raise VolumeError(f"expression is {len(text)} characters long; keep it under {MAX_LENGTH}")
    try:
        return _Parser(text).parse()
    except RecursionError:  # only if called already deep in the stack: MAX_DEPTH keeps the parser shallow
        raise VolumeError(f"expression nests too deeply to parse here; use at most {MAX_DEPTH} levels "
                          f"of parentheses, function calls and exponents") from None


# --- walking a tree without recursion ------------------------------------------------------

def _children(node) -> tuple:
    if isinstance(node, Unary):
        return (node.operand,)
    if isinstance(node, Binary):
        return (node.left, node.right)
    if isinstance(node, Call):
        return node.args
    return ()


def postorder(tree) -> list:
    """Every node, operands before the node that uses them, with an explicit stack: a tree as deep
    as x+x+...+x (one level per term) costs no Python recursion."""
    order, stack = [], [(tree, False)]
    while stack:
        node, expanded = stack.pop()
        children = _children(node)
        if expanded or not children:
            order.append(node)
        else:
            stack.append((node, True))
            stack.extend((child, False) for child in reversed(children))
    return order


def peak_intermediates(tree) -> int:
    """The most computed (grid-sized) values `evaluate` holds at once; numbers and x, y, z don't count."""
    held = peak = 0
    for node in postorder(tree):
        if _children(node):
            held = held - sum(1 for child in _children(node) if _children(child)) + 1
            peak = max(peak, held)
    return max(peak, 1)


# Rough milliseconds llvmpipe takes to compile each GLSL helper (the ex_* functions are inlined
# at every use); measured with 50-150 distinct calls of each in one shader.
_GLSL_COMPILE_MS = {"^": 25, "/": 25, "sin": 15, "cos": 15, "tan": 15, "exp": 15, "log": 15, "sqrt": 15,
                    "min": 10, "max": 10}


def glsl_compile_ms(tree) -> int:
    """An estimate of the milliseconds a GLSL compiler (llvmpipe's) needs for `to_glsl(tree)`."""
    total = 0
    for node in postorder(tree):
        if isinstance(node, Binary):
            total += _GLSL_COMPILE_MS.get(node.op, 1)
        elif isinstance(node, Call):
            total += _GLSL_COMPILE_MS.get(node.function, 1)
        elif isinstance(node, Unary):
            total += 1
    return total


# --- numpy evaluation (the CPU back end and the GPU's reference) -------------------------

def flush_denormals(values, tiny: float = FLOAT32_TINY):
    """Values below the smallest normal float32 become a zero of their sign, as on a GPU."""
    values = np.asarray(values)
    small = (np.abs(values) < tiny) & (values != 0)
    if np.any(small):
        values = np.where(small, np.copysign(values.dtype.type(0), values), values)
    return values


def _minimum(a, b):
    # IEEE 754-2019 minimum: NaN if either is NaN, -0 below +0 (the order numpy leaves open).
    zeros = (a == 0) & (b == 0)
    result = np.where(b < a, b, a)
    result = np.where(zeros, np.where(np.signbit(a) | np.signbit(b), -0.0, 0.0).astype(result.dtype), result)
    return np.where(np.isnan(a) | np.isnan(b), result.dtype.type(np.nan), result)


def _maximum(a, b):
    zeros = (a == 0) & (b == 0)
    result = np.where(b > a, b, a)
    result = np.where(zeros, np.where(np.signbit(a) & np.signbit(b), -0.0, 0.0).astype(result.dtype), result)
    return np.where(np.isnan(a) | np.isnan(b), result.dtype.type(np.nan), result)


def _odd_integer(b):
    return (np.abs(b) < 2 ** 24) & (np.floor(b) == b) & (np.fmod(b, 2) != 0)


def _power(a, b):
    # C99 powf, except the commonest powers, which the GPU computes exactly so: a*a, a, 1/a.
    result = np.power(a, b)
    # numpy's SIMD and scalar loops disagree with each other and C99 on some of these:
    # (-inf)^0.5 is NaN or Inf, (-0)^0.5 is -0 rather than +0.  So they are spelled out.
    special = ((a == 0) | np.isinf(a)) & ~np.isnan(b) & (b != 0)
    if np.any(special):
        grows = np.where(a == 0, b < 0, b > 0)  # 0^-2 and inf^2 are Inf, 0^2 and inf^-2 are 0
        magnitude = np.where(grows, np.inf, 0.0).astype(result.dtype)
        negative = np.signbit(a) & _odd_integer(b)
        result = np.where(special, np.where(negative, -magnitude, magnitude), result)
    if np.any(b == 2):
        result = np.where(b == 2, np.multiply(a, a), result)
    if np.any(b == 1):
        result = np.where(b == 1, a, result)
    if np.any(b == -1):
        result = np.where(b == -1, np.divide(result.dtype.type(1), a), result)
    return result


_NUMPY_FUNCTIONS = {
    "sin": np.sin, "cos": np.cos, "tan": np.tan, "exp": np.exp, "log": np.log,
    "sqrt": np.sqrt, "abs": np.abs, "min": _minimum, "max": _maximum,
}
_NUMPY_OPERATORS = {"+": np.add, "-": np.subtract, "*": np.multiply, "/": np.divide, "^": _power}


def evaluate(tree, x, y, z, dtype=np.float32):
    """Evaluate on numpy arrays (broadcasting), with IEEE results for undefined maths.

    float32 by default, as the GPU computes, so both back ends overflow, cancel and
    round alike, and flush denormal results to zero as the GPU does; pass np.float64
    for a reference of higher precision (no flushing).
    """
    flush = (lambda v: flush_denormals(v)) if np.dtype(dtype) == np.float32 else (lambda v: v)
    number = np.dtype(dtype).type  # a numpy scalar of the same type keeps the arithmetic in dtype
    with np.errstate(all="ignore"):  # NaN/Inf are reported by the volume checks, with a fix
        variables = {name: flush(np.asarray(value, dtype=dtype)) for name, value in zip(VARIABLES, (x, y, z))}
        values = []
        for node in postorder(tree):
            if isinstance(node, Number):
                values.append(flush(number(node.value)))
            elif isinstance(node, Variable):
                values.append(variables[node.name])
            elif isinstance(node, Unary):
                values.append(np.negative(values.pop()))
            elif isinstance(node, Binary):
                right = values.pop()
                values.append(flush(_NUMPY_OPERATORS[node.op](values.pop(), right)))
            else:
                args = values[-len(node.args):]
                del values[-len(node.args):]
                values.append(flush(_NUMPY_FUNCTIONS[node.function](*args)))
        return values[0]


# --- GLSL emission -----------------------------------------------------------------------

# GLSL leaves much of this maths undefined (log, sqrt, pow outside their domain, 1/0, NaN
# inputs) and lets the compiler fold 0*v to 0 and v-v to 0; the ex_* helpers in
# shaders/expr_functions.glsl compute each operation exactly as `evaluate` does.
GLSL_FUNCTIONS = {
    "sin": "ex_sin", "cos": "ex_cos", "tan": "ex_tan", "exp": "ex_exp", "log": "ex_log",
    "sqrt": "ex_sqrt", "abs": "ex_abs", "min": "ex_min", "max": "ex_max",
}
GLSL_OPERATORS = {"+": "ex_add", "-": "ex_sub", "*": "ex_mul", "/": "ex_div", "^": "ex_pow"}


@dataclass(frozen=True)
class GlslCode:
    """`body`: the statements of `float field(float x, float y, float z)`, ending in a return.
    `numbers`: the formula's numbers, which the body reads as inputs[0], inputs[1], ...: a
    compiler cannot fold what it cannot see, and GLSL compilers fold 0*v to 0 even where the
    result is `precise` (0*log(-1) is NaN, not 0)."""
    body: str
    numbers: np.ndarray  # float32, as `evaluate` rounds and flushes them


def to_glsl(tree, first_input: int = 0) -> GlslCode:
    """One GLSL statement per operation, then a return: straight-line code, so a formula of a
    thousand terms is a thousand short statements rather than a thousand nested parentheses
    for the GLSL compiler to recurse through.  The numbers are read from inputs[first_input]
    on (several formulas can share one buffer)."""
    statements, values, numbers = [], [], {}
    for node in postorder(tree):
        if isinstance(node, Number):
            value = flush_denormals(np.float32(node.value))
            index = numbers.setdefault(value.tobytes(), len(numbers))  # by bits: 0 and -0 differ
            values.append(f"inputs[{first_input + index}]")
            continue
        if isinstance(node, Variable):
            values.append(node.name)
            continue
        if isinstance(node, Unary):
            call = f"ex_neg({values.pop()})"
        elif isinstance(node, Binary):
            right = values.pop()
            call = f"{GLSL_OPERATORS[node.op]}({values.pop()}, {right})"
        else:
            args = values[-len(node.args):]
            del values[-len(node.args):]
            call = f"{GLSL_FUNCTIONS[node.function]}({', '.join(args)})"
        name = f"t{len(statements)}"
        statements.append(f"precise float {name} = {call};")
        values.append(name)
    statements.append(f"return {values[0]};")
    table = np.frombuffer(b"".join(numbers), dtype=np.float32) if numbers else np.zeros(0, np.float32)
    return GlslCode(" ".join(statements), table)
