"""The .pyi stub editors complete from names everything the compiled module has (functions,
classes and their members), and every public name has a docstring."""

import ast
import os

import odyssey
from odyssey import _odyssey


def stub_names():
    tree = ast.parse(open(os.path.join(os.path.dirname(odyssey.__file__), "_odyssey.pyi")).read())
    names = {}
    for node in tree.body:
        if isinstance(node, (ast.FunctionDef, ast.ClassDef)):
            members = {n.name for n in getattr(node, "body", []) if isinstance(n, ast.FunctionDef)}
            members |= {t.id for n in getattr(node, "body", []) if isinstance(n, ast.AnnAssign) for t in [n.target]}
            names[node.name] = members
    return names


def test_the_stub_names_every_public_name():
    stub = stub_names()
    for name in dir(_odyssey):
        if name.startswith("_"):
            continue
        assert name in stub, name
        value = getattr(_odyssey, name)
        if isinstance(value, type) and not issubclass(value, BaseException):
            for member in vars(value):
                if not member.startswith("_"):
                    assert member in stub[name], "%s.%s" % (name, member)
    assert set(odyssey.__all__) == {n for n in dir(_odyssey) if not n.startswith("_")}


def test_every_public_name_has_a_docstring():
    for name in odyssey.__all__:
        value = getattr(odyssey, name)
        assert value.__doc__ and value.__doc__.strip(), name
    assert odyssey.retarget.__doc__.count("quality") >= 1 and "InputError" in odyssey.retarget.__doc__
