"""The implicit-function language users type: parse once, then evaluate with numpy or emit GLSL.

Grammar (whitelist; nothing else is accepted):

    expr    := term (("+" | "-") term)*
    term    := unary (("*" | "/") unary)*
    unary   := ("-" | "+") unary | power
    power   := atom ("^" unary)?          # right-associative: 2^3^2 = 2^9; -x^2 = -(x^2)
    atom    := NUMBER | "x" | "y" | "z" | "pi" | FUNC "(" expr ("," expr)* ")" | "(" expr ")"
    FUNC    := sin cos tan exp log sqrt abs (one argument) | min max (two)

Both back ends give IEEE semantics where the maths is undefined (log(-1) and
sqrt(-1) are NaN, 1/0 is Inf, a negative base to a fractional power is NaN),
so the finite-values check after sampling catches the same cases on CPU and GPU.
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
MAX_LENGTH = 2000  # far beyond any formula a person types; bounds parser recursion too
MAX_DEPTH = 100

_TOKEN = re.compile(r"""
    (?P<number>(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)
  | (?P<name>[A-Za-z_][A-Za-z_0-9]*)
  | (?P<op>[-+*/^(),])
  | (?P<space>\s+)
""", re.VERBOSE)


# --- the syntax tree ---------------------------------------------------------------------

@dataclass(frozen=True)
class Number:
    value: float


@dataclass(frozen=True)
class Variable:
    name: str  # "x", "y" or "z"


@dataclass(frozen=True)
class Unary:
    op: str  # "-" (a unary "+" is dropped by the parser)
    operand: object


@dataclass(frozen=True)
class Binary:
    op: str  # + - * / ^
    left: object
    right: object


@dataclass(frozen=True)
class Call:
    function: str
    args: tuple


@dataclass(frozen=True)
class Token:
    kind: str  # number, name, op, end
    text: str
    column: int  # 1-based, for messages


def _error(text: str, column: int, problem: str, fix: str) -> VolumeError:
    # Quote the neighbourhood of a long formula so the message stays one readable line.
    start = max(0, column - 30)
    excerpt = ("..." if start else "") + text[start:column + 30] + ("..." if column + 30 < len(text) else "")
    return VolumeError(f"expression error at column {column}: {problem} in \"{excerpt}\"; {fix}")


def tokenize(text: str) -> list[Token]:
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
        return self.tokens[self.index]

    def take(self) -> Token:
        token = self.token
        self.index += 1
        return token

    def fail(self, token: Token, problem: str, fix: str):
        raise _error(self.text, token.column, problem, fix)

    def expect(self, op: str) -> None:
        if self.token.text != op or self.token.kind != "op":
            found = "the end" if self.token.kind == "end" else f"{self.token.text!r}"
            self.fail(self.token, f"expected {op!r} but found {found}", f"add the missing {op!r}")
        self.take()

    def parse(self):
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
        return self.left_associative(("+", "-"), self.term)

    def term(self):
        return self.left_associative(("*", "/"), self.unary)

    def left_associative(self, ops: tuple[str, ...], operand):
        node = operand()
        while self.token.kind == "op" and self.token.text in ops:
            op = self.take().text
            node = Binary(op, node, operand())
        return node

    def unary(self):
        if self.token.kind == "op" and self.token.text in ("-", "+"):
            op = self.take().text
            operand = self.nested(self.unary)
            return Unary("-", operand) if op == "-" else operand
        return self.power()

    def power(self):
        base = self.atom()
        if self.token.kind == "op" and self.token.text == "^":
            self.take()
            return Binary("^", base, self.nested(self.unary))
        return base

    def nested(self, rule):
        # Recursion depth is bounded so "((((..." gives a message, not a RecursionError.
        self.depth += 1
        if self.depth > MAX_DEPTH:
            self.fail(self.token, "the expression nests too deeply", f"use fewer than {MAX_DEPTH} levels")
        try:
            return rule()
        finally:
            self.depth -= 1

    def atom(self):
        token = self.take()
        if token.kind == "number":
            value = float(token.text)
            if not math.isfinite(value) or abs(value) > float(np.finfo(np.float32).max):
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
    return _Parser(text).parse()


# --- numpy evaluation (the CPU back end and the GPU's reference) -------------------------

_NUMPY_FUNCTIONS = {
    "sin": np.sin, "cos": np.cos, "tan": np.tan, "exp": np.exp, "log": np.log,
    "sqrt": np.sqrt, "abs": np.abs, "min": np.minimum, "max": np.maximum,
}
_NUMPY_OPERATORS = {"+": np.add, "-": np.subtract, "*": np.multiply, "/": np.divide, "^": np.power}


def evaluate(tree, x, y, z, dtype=np.float32):
    """Evaluate on numpy arrays (broadcasting), with IEEE results for undefined maths.

    float32 by default, as the GPU computes, so both back ends overflow, cancel and
    round alike; pass np.float64 for a reference of higher precision.
    """
    variables = {name: np.asarray(value, dtype=dtype) for name, value in zip(VARIABLES, (x, y, z))}
    number = np.dtype(dtype).type  # a numpy scalar of the same type keeps the arithmetic in dtype

    def walk(node):
        if isinstance(node, Number):
            return number(node.value)
        if isinstance(node, Variable):
            return variables[node.name]
        if isinstance(node, Unary):
            return np.negative(walk(node.operand))
        if isinstance(node, Binary):
            return _NUMPY_OPERATORS[node.op](walk(node.left), walk(node.right))
        return _NUMPY_FUNCTIONS[node.function](*(walk(arg) for arg in node.args))

    with np.errstate(all="ignore"):  # NaN/Inf are reported by the volume checks, with a fix
        return walk(tree)


# --- GLSL emission -----------------------------------------------------------------------

# GLSL's own log/sqrt/pow are undefined outside their domain; the ex_* helpers in
# shaders/expr_functions.glsl give numpy's answers instead.
GLSL_FUNCTIONS = {
    "sin": "sin", "cos": "cos", "tan": "tan", "exp": "exp", "log": "ex_log",
    "sqrt": "ex_sqrt", "abs": "abs", "min": "ex_min", "max": "ex_max",
}


def glsl_float(value: float) -> str:
    """A GLSL float literal for a Python float; repr() round-trips, GLSL needs a '.' or exponent."""
    text = repr(float(value))
    return text if ("." in text or "e" in text) else text + ".0"


def to_glsl(tree) -> str:
    """One GLSL expression of the float variables x, y, z."""
    if isinstance(tree, Number):
        return f"({glsl_float(tree.value)})"
    if isinstance(tree, Variable):
        return tree.name
    if isinstance(tree, Unary):
        return f"(-{to_glsl(tree.operand)})"
    if isinstance(tree, Binary):
        if tree.op == "^":
            return f"ex_pow({to_glsl(tree.left)}, {to_glsl(tree.right)})"
        return f"({to_glsl(tree.left)} {tree.op} {to_glsl(tree.right)})"
    args = ", ".join(to_glsl(arg) for arg in tree.args)
    return f"{GLSL_FUNCTIONS[tree.function]}({args})"
