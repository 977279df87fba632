"""REP 149 `condition` expressions: a small recursive-descent parser and evaluator."""

from __future__ import annotations

import operator
import re
from collections.abc import Callable, Mapping
from functools import lru_cache
from typing import cast

from wsbuild.errors import ConditionError
from wsbuild.patterns import lazy

#: Values assumed for these variables when the environment leaves them unset (or empty).
DEFAULT_VARIABLES: Mapping[str, str] = {
    "ROS_VERSION": "2",
    "ROS_DISTRO": "jazzy",
    "ROS_PYTHON_VERSION": "3",
}

GRAMMAR_HINT = (
    "write comparisons of $VARIABLES and literals with == != < <= > >=, "
    "joined by 'and'/'or' and parentheses, as REP 149 defines"
)
_QUOTE_HINT = (
    "quote literals that contain characters other than letters, digits, '_' and '-', "
    'e.g. "3.12"'
)

# One token per match; the alternatives mirror catkin_pkg's pyparsing grammar:
# identifier = '$' + alphanums/_ ; value = alphanums/_/- ; quoted = "..." or '...'.
_TOKEN = re.compile(
    r"""\s*(?:
        (?P<op>==|!=|<=|>=|<|>)
      | (?P<paren>[()])
      | \$(?P<var>[A-Za-z0-9_]+)
      | (?P<word>[A-Za-z0-9_-]+)
      | "(?P<dq>[^"]*)"
      | '(?P<sq>[^']*)'
    )""",
    re.VERBOSE,
)
_TRAILING_SPACE = lazy(r"\s*\Z")

_OPERATORS: dict[str, Callable[[str, str], bool]] = {
    "==": operator.eq,
    "!=": operator.ne,
    "<": operator.lt,
    "<=": operator.le,
    ">": operator.gt,
    ">=": operator.ge,
}

# Token kinds.
_OP, _LPAREN, _RPAREN, _VAR, _WORD, _LITERAL, _AND, _OR, _END = range(9)

Environ = Mapping[str, str]
_Term = Callable[[Environ], str]
_Node = Callable[[Environ], bool]


def evaluate_condition(expr: str, environ: Mapping[str, str]) -> bool:
    """Evaluate a REP 149 condition; `$VAR`s come from `environ` (see DEFAULT_VARIABLES).

    Like catkin_pkg, every operand is a string and `<`/`>` compare strings, so
    `"10" < "9"` is true. Raises ConditionError naming what is wrong.
    """
    return _compile(expr)(environ)


def check_condition(expr: str) -> None:
    """Raise ConditionError if `expr` is not a valid REP 149 condition."""
    _compile(expr)


@lru_cache(maxsize=4096)
def _compile(expr: str) -> _Node:
    # Conditions repeat across a workspace ("$ROS_VERSION == 2"), so each is parsed once.
    parser = _Parser(expr, _tokenize(expr))
    node = parser.parse_or()
    kind, text, column = parser.peek()
    if kind is not _END:
        raise parser.error(f"unexpected {text!r} at column {column}")
    return node


def _tokenize(expr: str) -> list[tuple[int, str, int]]:
    tokens: list[tuple[int, str, int]] = []
    pos = 0
    end = len(expr)
    match = _TOKEN.match
    while True:
        m = match(expr, pos)
        if m is None:
            if _TRAILING_SPACE.match(expr, pos):
                break
            start = len(expr) - len(expr[pos:].lstrip())
            char = expr[start]
            hint = GRAMMAR_HINT
            if char in "\"'":
                problem = f"unterminated quoted literal starting at column {start + 1}"
                hint = (
                    f"close it with {char}; a quoted literal cannot contain its own quote character"
                )
            elif char == "$":
                problem = f"'$' at column {start + 1} is not followed by a variable name"
                hint = "variable names are letters, digits and '_', e.g. $ROS_DISTRO"
            elif char == "=":
                problem = f"single '=' at column {start + 1}"
                hint = "use '==' to compare"
            else:
                problem = f"unexpected character {char!r} at column {start + 1}"
                if char not in "&|!":
                    hint = _QUOTE_HINT
            raise ConditionError(f"condition {expr!r} is malformed: {problem}", hint=hint)
        group = cast(str, m.lastgroup)  # every alternative is a named group
        column = m.start(group) + 1 if group not in ("dq", "sq") else m.start(group)
        value = m.group(group)
        if group == "op":
            tokens.append((_OP, value, column))
        elif group == "paren":
            tokens.append((_LPAREN if value == "(" else _RPAREN, value, column))
        elif group == "var":
            tokens.append((_VAR, value, column - 1))
        elif group == "word":
            kind = _AND if value == "and" else _OR if value == "or" else _WORD
            tokens.append((kind, value, column))
        else:
            tokens.append((_LITERAL, value, column))
        pos = m.end()
        if pos >= end:
            break
    return tokens


class _Parser:
    """expr := and_expr ('or' and_expr)* ; and_expr := atom ('and' atom)* ;
    atom := '(' expr ')' | term OP term ; term := $VAR | word | quoted."""

    __slots__ = ("expr", "tokens", "index")

    def __init__(self, expr: str, tokens: list[tuple[int, str, int]]) -> None:
        self.expr = expr
        self.tokens = tokens
        self.index = 0

    def peek(self) -> tuple[int, str, int]:
        if self.index < len(self.tokens):
            return self.tokens[self.index]
        return (_END, "", len(self.expr) + 1)

    def error(self, problem: str) -> ConditionError:
        if not self.expr.strip():
            return ConditionError("condition is empty", hint=GRAMMAR_HINT)
        return ConditionError(f"condition {self.expr!r} is malformed: {problem}", hint=GRAMMAR_HINT)

    def found(self) -> str:
        kind, text, column = self.peek()
        if kind is _END:
            return "the end of the condition"
        if kind is _VAR:
            return f"'${text}' at column {column}"
        if kind is _LITERAL:
            return f"quoted literal {text!r} at column {column}"
        return f"{text!r} at column {column}"

    def parse_or(self) -> _Node:
        operands = [self.parse_and()]
        while self.peek()[0] is _OR:
            self.index += 1
            operands.append(self.parse_and())
        if len(operands) == 1:
            return operands[0]
        nodes = tuple(operands)
        return lambda env: any(node(env) for node in nodes)

    def parse_and(self) -> _Node:
        operands = [self.parse_atom()]
        while self.peek()[0] is _AND:
            self.index += 1
            operands.append(self.parse_atom())
        if len(operands) == 1:
            return operands[0]
        nodes = tuple(operands)
        return lambda env: all(node(env) for node in nodes)

    def parse_atom(self) -> _Node:
        if self.peek()[0] is _LPAREN:
            column = self.peek()[2]
            self.index += 1
            node = self.parse_or()
            if self.peek()[0] is not _RPAREN:
                raise self.error(
                    f"the '(' at column {column} is not closed: "
                    f"expected ')' but found {self.found()}"
                )
            self.index += 1
            return node
        left = self.parse_term()
        kind, text, _column = self.peek()
        if kind is not _OP:
            raise self.error(
                f"expected a comparison operator (== != < <= > >=) but found {self.found()}"
            )
        self.index += 1
        compare = _OPERATORS[text]
        right = self.parse_term()
        return lambda env: compare(left(env), right(env))

    def parse_term(self) -> _Term:
        kind, text, _column = self.peek()
        if kind is _VAR:
            self.index += 1
            return _variable(text)
        # catkin_pkg accepts the bare words 'and'/'or' as operands too.
        if kind is _WORD or kind is _LITERAL or kind is _AND or kind is _OR:
            self.index += 1
            return lambda env: text
        raise self.error(f"expected a $VARIABLE or a literal but found {self.found()}")


def _variable(name: str) -> _Term:
    default = DEFAULT_VARIABLES.get(name)
    if default is None:
        return lambda env: env.get(name, "")
    return lambda env: env.get(name) or default
