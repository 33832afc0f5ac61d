"""The error policy, read from the source: library code raises the workbench's classes, not bare builtins.

An expected error is a :class:`model.errors.InputError`, :class:`~model.errors.NumericalError` or
:class:`~model.errors.ToolchainError` (or a subclass naming the domain), carrying the parameter it
concerns; the command line prints those as one line. A bare ``ValueError`` or ``RuntimeError``
escapes that policy: ``manip`` would show its traceback. Every ``raise`` statement of every module
under model/, control_design/, closed_loop/, fmu/ and workbench/ is read with ``ast`` (as
tests/project/test_layers.py reads the imports).

An entry of :data:`ALLOWED` needs the reason a caller relies on the builtin itself (e.g. a protocol that
requires it), or the reason the raise can only report a bug of ours, for which a traceback is right.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

from model.errors import InputError, NumericalError, ToolchainError, WorkbenchError

REPO = Path(__file__).resolve().parents[2]
PACKAGES = ("model", "control_design", "closed_loop", "fmu", "workbench")
#: The builtins whose ``raise`` bypasses the policy.
BARE = {"ValueError", "RuntimeError", "Exception", "ArithmeticError"}
#: ``"path:function"`` -> why the builtin is right there.
ALLOWED: dict[str, str] = {
    "model/lazy.py:lazy_exports": "two submodules exporting one name is a bug in a package's own __init__ "
                                  "table, raised when the package is imported: no user input reaches it",
}


def _raised_names(exc: ast.expr | None) -> list[str]:
    """The class names a ``raise`` statement's expression can raise (``X``, ``X(...)``, ``(A if c else B)(...)``)."""
    if exc is None:
        return []
    if isinstance(exc, ast.Call):
        return _raised_names(exc.func)
    if isinstance(exc, ast.IfExp):
        return _raised_names(exc.body) + _raised_names(exc.orelse)
    if isinstance(exc, ast.Name):
        return [exc.id]
    if isinstance(exc, ast.Attribute):  # builtins.ValueError
        return [exc.attr] if isinstance(exc.value, ast.Name) and exc.value.id == "builtins" else []
    return []


def bare_raises(source: str, where: str) -> list[str]:
    """``"where:line: raise NAME in FUNCTION"`` for every raise of a :data:`BARE` builtin in ``source``."""
    tree = ast.parse(source, where)
    found = []
    shadowed = {node.name for node in ast.walk(tree) if isinstance(node, ast.ClassDef)}

    def visit(node: ast.AST, function: str) -> None:
        for child in ast.iter_child_nodes(node):
            name = child.name if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)) else function
            if isinstance(child, ast.Raise):
                for cls in _raised_names(child.exc):
                    if cls in BARE and cls not in shadowed and f"{where}:{function}" not in ALLOWED:
                        found.append(f"{where}:{child.lineno}: raise {cls} in {function}")
            visit(child, name)

    visit(tree, "<module>")
    return found


def test_no_library_module_raises_a_bare_builtin():
    files = sorted(p for pkg in PACKAGES for p in (REPO / pkg).rglob("*.py"))
    assert len(files) > 80  # negative control: the walk sees the packages
    found = [hit for path in files for hit in bare_raises(path.read_text(), str(path.relative_to(REPO)))]
    assert found == [], "raise InputError / NumericalError / ToolchainError (model/errors.py) instead:\n" + "\n".join(found)


@pytest.mark.parametrize(("source", "expected"), [
    ("def f(x):\n    raise ValueError(f'x: bad {x}')\n", ["t.py:2: raise ValueError in f"]),
    ("def f():\n    raise RuntimeError\n", ["t.py:2: raise RuntimeError in f"]),
    ("def f(s):\n    raise (ValueError if s else InputError)('no')\n", ["t.py:2: raise ValueError in f"]),
    ("import builtins\nraise builtins.RuntimeError('x')\n", ["t.py:2: raise RuntimeError in <module>"]),
    ("def f():\n    raise InputError('bad', parameter='x')\n", []),
    ("def f():\n    raise\n", []),
])
def test_the_check_finds_what_it_should(source, expected):
    """Negative controls of the reader: each form of a bare raise is found, the policy's classes are not."""
    assert bare_raises(source, "t.py") == expected


def test_the_policy_classes_carry_the_parameter_through_str_and_pickling():
    import pickle

    for cls in (InputError, NumericalError, ToolchainError):
        err = cls("expected a factor > 0, got 0.0", parameter="link_mass_scale")
        assert isinstance(err, WorkbenchError)
        assert str(err) == "link_mass_scale: expected a factor > 0, got 0.0"
        assert err.detail == "expected a factor > 0, got 0.0" and err.parameter == "link_mass_scale"
        back = pickle.loads(pickle.dumps(err))  # a sweep's worker sends its errors back pickled
        assert type(back) is cls and back.parameter == "link_mass_scale" and str(back) == str(err)
        assert str(cls("no parameter")) == "no parameter" and cls("x").parameter is None
