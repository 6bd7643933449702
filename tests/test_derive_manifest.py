"""``generated/MANIFEST``: a model whose inputs and files are unchanged is not derived again;
anything else about it is, and ``--force`` derives every model."""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import cached_render_model

import derive.__main__ as derive_main
from derive import manifest
from derive.__main__ import existing_files, main, write_atomically
from derive.registry import MODEL_NAMES

_LOG: dict[str, Path] = {}


def logged_render_model(name: str) -> dict[str, str]:
    """The test run's rendering of a model, logged (module level: forked workers call it)."""
    with open(_LOG["path"], "a") as fh:
        fh.write(name + "\n")
    return cached_render_model(name)


@pytest.fixture
def derived_log(cached_derivation, monkeypatch, tmp_path):
    """The test run's derivation in a temporary ``generated/``, and a log of the models the
    command derives (a file: the workers are forked processes)."""
    log = tmp_path / "derived.log"
    log.write_text("")
    monkeypatch.setattr(derive_main, "_render_model", logged_render_model)
    monkeypatch.setitem(_LOG, "path", log)
    out = tmp_path / "generated"
    write_atomically(cached_derivation, out)

    def derived() -> list[str]:
        names = sorted(log.read_text().split())
        log.write_text("")
        return names

    return out, derived


def test_the_manifest_is_part_of_the_tree(rendered_tree):
    entries = manifest.parse(rendered_tree[manifest.MANIFEST])
    assert sorted(entries) == sorted([manifest.SHARED, *MODEL_NAMES])
    listed = {p for e in entries.values() for p in e.files}
    assert listed == set(rendered_tree) - {manifest.MANIFEST}
    assert {e.inputs for e in entries.values()} == set(manifest.input_digests().values())


def test_nothing_changed_derives_nothing(derived_log, capsys):
    out, derived = derived_log
    assert main(["--check", "--out", str(out)]) == 0
    assert main(["--out", str(out)]) == 0
    assert derived() == []
    assert "--force derives them" in capsys.readouterr().out


def test_force_derives_every_model(derived_log):
    out, derived = derived_log
    assert main(["--check", "--force", "--out", str(out)]) == 0
    assert derived() == sorted(MODEL_NAMES)


def test_an_edited_file_rederives_its_model_only_and_check_names_it(derived_log, capsys):
    out, derived = derived_log
    target = out / "compass_gait" / "c" / "compass_gait.h"
    target.write_text(target.read_text() + "/* hand edit */\n")
    assert main(["--check", "--out", str(out)]) == 1
    assert "compass_gait.h" in capsys.readouterr().err
    assert derived() == ["compass_gait"]
    assert main(["--out", str(out)]) == 0
    assert derived() == ["compass_gait"]
    assert "hand edit" not in target.read_text()
    assert main(["--check", "--out", str(out)]) == 0
    assert derived() == []


def test_changed_inputs_rederive_that_model(derived_log, monkeypatch):
    out, derived = derived_log
    digests = manifest.input_digests()
    monkeypatch.setattr(manifest, "input_digests", lambda: {**digests, "rimless_wheel": "0" * 64})
    assert main(["--out", str(out)]) == 0
    assert derived() == ["rimless_wheel"]
    # The new digest is recorded: a second run derives nothing.
    assert manifest.parse((out / manifest.MANIFEST).read_text())["rimless_wheel"].inputs == "0" * 64
    assert main(["--check", "--out", str(out)]) == 0
    assert derived() == []


@pytest.mark.parametrize("damage", ["malformed", "missing", "extra file in a model"])
def test_a_damaged_manifest_or_tree_is_never_trusted(derived_log, damage):
    out, derived = derived_log
    if damage == "malformed":
        (out / manifest.MANIFEST).write_text("inputs\n")
        expected = sorted(MODEL_NAMES)
    elif damage == "missing":
        (out / manifest.MANIFEST).unlink()
        expected = sorted(MODEL_NAMES)
    else:
        (out / "tle" / "c" / "notes.txt").write_text("mine\n")
        expected = ["tle"]
    assert main(["--check", "--out", str(out)]) == 1
    assert derived() == expected


def test_model_sources_follow_imports_of_other_models():
    """The biped takes the ILE's parameter table: an edit there re-derives it too."""
    root = manifest.SOURCE_ROOT
    biped = {
        p.relative_to(root).as_posix() for p in manifest.model_sources("derive.models.vsw_biped")
    }
    assert "derive/models/vsw_biped.py" in biped
    assert "derive/models/ile/model.py" in biped
    assert not any("compass_gait" in p for p in biped)


def test_check_of_the_repository_is_fast_when_nothing_changed(monkeypatch):
    """Nothing is derived on the committed tree: the stop hook's check reads files only
    (the models' renderer must not even be called)."""
    monkeypatch.setattr(derive_main, "_render_model", _never)
    monkeypatch.setattr(derive_main, "_render_shared", _never)
    files = derive_main.render_all(None, existing_files(derive_main.ROOT / "generated"), reuse=True)
    assert files == existing_files(Path(derive_main.ROOT) / "generated")


def _never(*args):
    raise AssertionError("derived although nothing changed")


@pytest.mark.parametrize("damage", ["edited", "removed"])
def test_deriving_one_model_does_not_vouch_for_the_others(derived_log, capsys, damage):
    """``--model X`` writes the other models' entries as recorded: an edit or a removal of
    another model on disk is still found by the next check (found in review)."""
    out, derived = derived_log
    if damage == "edited":
        target = out / "ile" / "__init__.py"
        target.write_text(target.read_text() + "# hand edit\n")
    else:
        for path in sorted((out / "tle").rglob("*"), reverse=True):
            path.unlink() if path.is_file() else path.rmdir()
        (out / "tle").rmdir()
    assert main(["--model", "rimless_wheel", "--force", "--out", str(out)]) == 0
    assert derived() == ["rimless_wheel"]
    capsys.readouterr()
    assert main(["--check", "--out", str(out)]) == 1
    err = capsys.readouterr().err
    assert ("generated/ile/__init__.py" if damage == "edited" else "missing: generated/tle/") in err
