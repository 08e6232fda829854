"""The `vpro` command: help everywhere, clear one-line errors, snapshots."""

import subprocess
import sys

import cv2
import pytest

from vpro_assets.cli import build_parser

VPRO = [sys.executable, "-m", "vpro_assets.cli"]


def run(*args, timeout=300):
    return subprocess.run(VPRO + list(args), capture_output=True, text=True, timeout=timeout, stdin=subprocess.DEVNULL)


def subcommands(parser, prefix=()):
    for action in parser._subparsers._group_actions if parser._subparsers else []:
        for name, sub in action.choices.items():
            yield prefix + (name,), sub
            yield from subcommands(sub, prefix + (name,))


def test_every_subcommand_has_help():
    parser = build_parser()
    found = list(subcommands(parser))
    assert {p for p, _ in found} >= {
        ("tasks",),
        ("taxonomy",),
        ("catalog",),
        ("catalog", "build"),
        ("catalog", "verify"),
        ("env",),
    }
    for path, sub in found:
        text = sub.format_help()
        assert sub.description, f"`vpro {' '.join(path)}` has no description"
        assert "usage:" in text


def test_catalog_verify_passes_on_the_committed_catalog():
    proc = run("catalog", "verify")
    assert proc.returncode == 0, proc.stderr
    assert "3296 cases, 96 settings, 12 categories, 4 dimensions, 40 tasks" in proc.stdout


@pytest.mark.parametrize(
    "args, expected",
    [
        (("tasks", "libero_spatal-03"), "did you mean: libero_spatial-03"),
        (("taxonomy", "--category", "camera_stalenes"), "did you mean: camera_staleness"),
        (
            ("catalog", "show", "libero_goal-03/camera_staleness/wrist-delay9-v1"),
            "libero_goal-03/camera_staleness/wrist-delay",
        ),
        (("env", "libero_goal-99", "--snapshot", "/tmp/x.png"), "unknown task id"),
    ],
)
def test_unknown_ids_give_suggestions_not_tracebacks(args, expected):
    proc = run(*args)
    assert proc.returncode == 2
    assert expected in proc.stderr
    assert "Traceback" not in proc.stderr


def test_corrupt_catalog_is_an_error_without_traceback(tmp_path):
    bad = tmp_path / "catalog.json"
    bad.write_text('{"header": {"schema_version": 1, "totals": {"cases": 1}}, "cases": [')
    proc = run("catalog", "verify", "--catalog", str(bad))
    assert proc.returncode == 2 and "truncated" in proc.stderr and "Traceback" not in proc.stderr


def test_edited_catalog_fails_verify_naming_case_and_field(tmp_path):
    from vpro_assets.core import paths

    text = paths.catalog_path().read_text().replace('"delay_steps": 20', '"delay_steps": 21', 1)
    edited = tmp_path / "catalog.json"
    edited.write_text(text)
    proc = run("catalog", "verify", "--catalog", str(edited))
    assert proc.returncode == 1
    assert "camera_staleness/third_person-delay3-v1: field params.delay_steps: committed 21, rebuilt 20" in proc.stderr


def test_env_snapshot_writes_both_views(tmp_path):
    out = tmp_path / "snap.png"
    proc = run("env", "libero_object-02", "--snapshot", str(out), "--resolution", "96")
    assert proc.returncode == 0, proc.stderr
    image = cv2.imread(str(out))
    assert image.shape == (96, 192, 3)
    assert image[:, :96].std() > 5 and image[:, 96:].std() > 5


@pytest.mark.parametrize("results", ["/proc/no-such-dir/r.sqlite", "/proc/r.sqlite"])
def test_unwritable_results_path_is_a_one_line_error(results):
    proc = run(
        "eval",
        "--policy",
        "noop",
        "--select",
        "libero_goal-03/normal",
        "--trials",
        "1",
        "--results",
        results,
        "--no-progress",
    )
    assert proc.returncode == 2
    assert "Traceback" not in proc.stderr
    errors = [line for line in proc.stderr.splitlines() if "error" in line]
    assert errors == [f"vpro eval: error: results database {results}: " + errors[0].split(": ", 3)[3]], proc.stderr
