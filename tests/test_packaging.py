"""Shaders and sample volumes are found from a checkout and ship inside the wheel."""
import ast
import os
import subprocess
import sys
import zipfile
from pathlib import Path

from isoscope import resources

ROOT = Path(__file__).resolve().parent.parent


def test_shaders_are_found_and_includes_expand():
    assert (resources.shaders_dir() / "mc_signs.comp").is_file()
    source = resources.shader_source("mc_vertices.comp", {"MAX_TRIANGLES_PER_CELL": "5u"})
    assert "#include \"" not in source and "float field_at(ivec3 p)" in source
    assert source.splitlines()[0] == "#version 430"


def test_nothing_imports_the_source_folder_as_app():
    # app/ is installed as isoscope; an `import app` from the checkout would load a second copy
    # of every module (two GPULimitError classes, two shader caches).
    offenders = []
    for path in ROOT.rglob("*.py"):
        if {"build", ".venv", ".git"} & set(path.relative_to(ROOT).parts):
            continue
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import) else
                     [node.module or ""] if isinstance(node, ast.ImportFrom) and node.level == 0 else [])
            offenders += [f"{path.relative_to(ROOT)}:{node.lineno}" for n in names if n.split(".")[0] == "app"]
    assert not offenders, f"import isoscope instead: {offenders}"


def test_wheel_contains_shaders_volumes_and_the_console_script(tmp_path):
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
                    "-w", str(tmp_path), str(ROOT)], check=True)
    wheel = next(tmp_path.glob("isoscope-*.whl"))
    names = zipfile.ZipFile(wheel).namelist()
    shipped = {n.split("/", 2)[-1] for n in names if n.startswith("isoscope/_shaders/")}
    in_checkout = {p.name for p in (ROOT / "shaders").iterdir() if p.is_file()}
    assert in_checkout and in_checkout <= shipped
    modules = {"isoscope/" + str(p.relative_to(ROOT / "app")) for p in (ROOT / "app").rglob("*.py")}
    assert modules <= set(names), f"modules missing from the wheel: {sorted(modules - set(names))}"
    assert "isoscope/py.typed" in names   # PEP 561: type checkers read the package's annotations
    entry_points = next(n for n in names if n.endswith("entry_points.txt"))
    assert "isoscope = isoscope.launch:main" in zipfile.ZipFile(wheel).read(entry_points).decode()

    # Installed from the wheel (not editable), far from the checkout, it finds its own data.
    site = tmp_path / "site"
    subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--target", str(site),
                    str(wheel)], check=True)
    probe = ("from isoscope import resources, volumes; "
             "assert resources.shaders_dir().is_relative_to(sys.argv[1]), resources.shaders_dir(); "
             "assert '#version' in resources.shader_source('mesh.vert'); "
             "print(volumes.open_volume(volumes.sample_names()[0]).data.shape)")
    done = subprocess.run([sys.executable, "-c", "import sys; " + probe, str(site)], cwd=tmp_path,
                          env={**os.environ, "PYTHONPATH": str(site)}, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
