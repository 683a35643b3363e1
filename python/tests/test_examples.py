"""The examples stay in step with the API: they compile, and every `carom.` and `world.` name
they use exists. (Running them needs matplotlib, which the tests do not install.)"""

import ast
import json
import pathlib

import carom

EXAMPLES = pathlib.Path(__file__).resolve().parents[1] / "examples"


def sources():
    yield "lecture_demos.py", (EXAMPLES / "lecture_demos.py").read_text()
    notebook = json.loads((EXAMPLES / "lecture_demos.ipynb").read_text())
    assert notebook["nbformat"] == 4
    for i, cell in enumerate(notebook["cells"]):
        if cell["cell_type"] == "code":
            yield f"lecture_demos.ipynb cell {i}", "".join(cell["source"])


def test_examples_compile_and_use_real_names():
    world_names = set(dir(carom.World))
    seen = 0
    for where, text in sources():
        tree = ast.parse(text, where)
        for node in ast.walk(tree):
            if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name):
                if node.value.id == "carom":
                    assert hasattr(carom, node.attr), (where, node.attr)
                    seen += 1
                elif node.value.id in ("world", "gas"):
                    assert node.attr in world_names, (where, node.attr)
                    seen += 1
    assert seen > 10
