"""Python lint of the project (pyflakes), run by scripts/test.sh:
    /usr/bin/python3 scripts/lint.py [paths...]     (default: addon bench packaging scripts tests)

pyflakes reads every string inside an annotation as a forward reference. Blender's operator
properties are annotations that are calls (``eta1: FloatProperty(name="Similarity eta1")``), so
their names and descriptions came out as undefined names; here an annotation that is a call is
checked as the ordinary expression it is. A line marked ``# noqa`` is not reported. Everything else
is pyflakes unchanged."""

import ast
import pathlib
import sys

from pyflakes import checker

SKIP = {"build", "__pycache__", ".cache"}


class Checker(checker.Checker):
    def handleAnnotation(self, annotation, node):
        if isinstance(annotation, ast.Call):  # a bpy.props definition, not a type
            with self._enter_annotation(checker.AnnotationState.NONE):
                self.handleNode(annotation, node)
        else:
            super().handleAnnotation(annotation, node)


def files(paths):
    for p in map(pathlib.Path, paths):
        if p.is_file():
            yield p
        else:
            yield from (f for f in sorted(p.rglob("*.py")) if not SKIP & set(f.parts))


def main(argv):
    root = pathlib.Path(__file__).resolve().parent.parent
    paths = argv or [str(root / d) for d in ("addon", "bench", "packaging", "scripts", "tests")]
    problems = 0
    for f in files(paths):
        source = f.read_text(encoding="utf-8")
        try:
            tree = ast.parse(source, filename=str(f))
        except SyntaxError as exc:
            print(f"{f}:{exc.lineno}: {exc.msg}")
            problems += 1
            continue
        w = Checker(tree, filename=str(f))
        lines = source.splitlines()
        for m in sorted(w.messages, key=lambda m: m.lineno):
            if "# noqa" in lines[m.lineno - 1]:
                continue
            print(f"{f}:{m.lineno}: {m.message % m.message_args}")
            problems += 1
    print(f"lint: {problems} problem(s)" if problems else "lint: clean")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
