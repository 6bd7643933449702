"""Compiled batch kernels (generated/ile/c/ile_batch.c) against the generated numpy code."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import generated.ile as ile
from tests.conftest import random_valid_parameters, random_walking_parameters
from vsw.models.ile import kernels


def _compare(got, expected, tol):
    assert len(got) == len(expected) == kernels.N_OUTPUTS
    for k, (a, b) in enumerate(zip(got, expected)):
        b = np.broadcast_to(b, a.shape)  # numpy returns each output at its own shape
        assert np.array_equal(np.isnan(a), np.isnan(b)), k
        ok = np.isfinite(b)
        assert np.max(np.abs(a[ok] - b[ok]) / np.maximum(np.abs(b[ok]), 1.0)) <= tol, k


@pytest.fixture(scope="module")
def compiled():
    if kernels.library() is None:
        pytest.skip(kernels.build_error or "kernels disabled")
    return kernels.library()


@pytest.mark.parametrize("threads", [1, 2])
def test_kernel_matches_numpy_on_walking_sets(compiled, threads):
    p = random_walking_parameters(50000, seed=31)
    args = (p["beta"], p["theta_II"], p["phi0"])
    _compare(
        kernels.fixed_point_conditions(*args, threads=threads),
        ile.fixed_point_conditions(*args),
        1e-12,
    )


def test_kernel_matches_numpy_over_the_whole_domain(compiled):
    # Includes the corners (phi0 -> 0 with beta -> 1, beta -> 0), where the two tan
    # implementations' last bits are amplified most.
    p = random_valid_parameters(200000, seed=32)
    args = (p["beta"], p["theta_II"], p["phi0"])
    with np.errstate(all="ignore"):
        expected = ile.fixed_point_conditions(*args)
    _compare(kernels.fixed_point_conditions(*args), expected, 1e-11)


def test_kernel_broadcasts_and_handles_scalars_and_empty(compiled):
    beta = np.linspace(0.75, 0.95, 6)[:, None]
    out = kernels.fixed_point_conditions(beta, 0.05, np.full(4, 0.8))
    assert out[0].shape == (6, 4)
    _compare(out, ile.fixed_point_conditions(beta, 0.05, np.full(4, 0.8)), 1e-12)
    scalar = kernels.fixed_point_conditions(0.8, 0.0, np.pi / 4)
    assert scalar[0].shape == () and float(scalar[0]) == pytest.approx(0.465196423021, rel=1e-11)
    assert kernels.fixed_point_conditions(np.empty(0), 0.0, 0.5)[0].shape == (0,)


def test_without_kernels_the_numpy_code_answers(monkeypatch):
    monkeypatch.setenv("VSW_KERNELS", "0")
    p = random_walking_parameters(20000, seed=33)
    args = (p["beta"], p["theta_II"], p["phi0"])
    got = kernels.fixed_point_conditions(*args)
    for a, b in zip(got, ile.fixed_point_conditions(*args)):
        np.testing.assert_array_equal(a, b)


def test_kernel_source_is_plain_c99_without_warnings(tmp_path):
    import shutil
    import subprocess

    cc = shutil.which("cc") or shutil.which("gcc")
    if cc is None:
        pytest.skip("no C compiler")
    command = [cc, "-std=c99", "-Wall", "-Wextra", "-Werror", "-Wno-unknown-pragmas", "-c"]
    done = subprocess.run(
        [*command, str(kernels.SOURCE), "-o", str(tmp_path / "k.o")], capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr


def test_missing_compiler_falls_back_to_numpy_and_says_why(tmp_path):
    import subprocess
    import sys

    code = (
        "import numpy as np; from vsw.models.ile import kernels;"
        "q = kernels.fixed_point_conditions(np.full(3, 0.8), 0.0, 0.7)[0];"
        "print(kernels.build_error); print(float(q[0]))"
    )
    env = {"CC": str(tmp_path / "no-such-cc"), "VSW_CACHE_DIR": str(tmp_path), "PATH": ""}
    import os

    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, env={**os.environ, **env}
    )
    assert done.returncode == 0, done.stderr
    reason, value = done.stdout.strip().splitlines()
    assert reason.startswith("compiled kernels unavailable, using numpy:")
    assert float(value) == pytest.approx(float(ile.q_fixed(0.8, 0.0, 0.7)), rel=1e-15)


def test_large_analyses_use_the_kernel_and_agree_with_numpy(compiled, monkeypatch):
    from vsw.models.ile.analysis import _COMPILED_MIN_SIZE, analyze

    p = random_walking_parameters(_COMPILED_MIN_SIZE + 5000, seed=34)
    args = (p["beta"], p["theta_II"], p["phi0"])
    with_kernel = analyze(*args, timing=False)
    monkeypatch.setenv("VSW_KERNELS", "0")
    without = analyze(*args, timing=False)
    np.testing.assert_allclose(with_kernel.q_fixed, without.q_fixed, rtol=1e-12)
    np.testing.assert_array_equal(with_kernel.walks, without.walks)
    for a, b in zip(with_kernel.conditions, without.conditions):
        np.testing.assert_allclose(a.value, b.value, rtol=1e-11, atol=1e-12)


CHILD = """
import hashlib, sys
from pathlib import Path

import numpy as np
from vsw.models.ile import kernels
from tests.conftest import random_valid_parameters
p = random_valid_parameters(2 * kernels.CHUNK + 17, seed=35)  # several blocks, threaded
out = np.array(kernels.fixed_point_conditions(p["beta"], p["theta_II"], p["phi0"]))
print(kernels.build_error)
print(kernels.library_path)
print(hashlib.sha256(out.tobytes()).hexdigest())
"""


def _child(cache, **env):
    """Use the kernels in a fresh process (a SIGBUS there fails the test, not pytest)."""
    import os
    import subprocess
    import sys

    full = {**os.environ, "VSW_CACHE_DIR": str(cache), "VSW_KERNELS": "1", **env}
    done = subprocess.run(
        [sys.executable, "-c", CHILD], cwd=ROOT, env=full, capture_output=True, text=True
    )
    assert done.returncode == 0, f"exit {done.returncode}: {done.stderr[-2000:]}"
    error, path, digest = done.stdout.strip().splitlines()
    assert error == "None", error
    return Path(path), digest


ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture
def cached(compiled, tmp_path):
    """A fresh cache with one verified library: (cache, library, digest of the results)."""
    library, digest = _child(tmp_path)
    assert library.parent == tmp_path and library.with_name(library.name + ".json").exists()
    return tmp_path, library, digest


def _truncate_half(library: Path) -> None:
    data = library.read_bytes()
    library.write_bytes(data[: len(data) // 2])


def _zero(library: Path) -> None:
    library.write_bytes(b"")


def _flip_a_byte(library: Path) -> None:
    data = bytearray(library.read_bytes())
    data[len(data) // 2] ^= 0xFF
    library.write_bytes(bytes(data))


def _drop_sidecar(library: Path) -> None:
    library.with_name(library.name + ".json").unlink()


def _garble_sidecar(library: Path) -> None:
    library.with_name(library.name + ".json").write_text('{"size": 12')


def _truncate_with_a_forged_sidecar(library: Path) -> None:
    """Truncated, and a sidecar written to match it (tampering): the ELF check catches
    what the sidecar no longer can."""
    import hashlib
    import json

    sidecar = library.with_name(library.name + ".json")
    record = json.loads(sidecar.read_text())
    data = library.read_bytes()[: library.stat().st_size // 2]
    library.write_bytes(data)
    record.update(size=len(data), sha256=hashlib.sha256(data).hexdigest())
    sidecar.write_text(json.dumps(record))


@pytest.mark.parametrize(
    "damage",
    [_truncate_half, _zero, _flip_a_byte, _drop_sidecar, _garble_sidecar,
     _truncate_with_a_forged_sidecar],
)  # fmt: skip
def test_damaged_cached_library_is_rebuilt_with_the_same_flags(cached, damage):
    """A truncated library, mapped, gave SIGBUS run after run; an empty one made every
    later run fall back to the slower flags. Now either is verified and rebuilt."""
    cache, library, digest = cached
    intact = library.read_bytes()
    damage(library)
    again, digest_again = _child(cache)
    assert again == library  # the same key: the same flags, not the fallback
    assert digest_again == digest
    assert sorted(p.name for p in cache.glob("*.so")) == [library.name]
    # Rebuilt completely, and recorded: the sidecar describes the library on disk.
    import hashlib
    import json

    record = json.loads(library.with_name(library.name + ".json").read_text())
    data = library.read_bytes()
    assert record["size"] == len(data) and record["sha256"] == hashlib.sha256(data).hexdigest()
    assert len(data) == len(intact)


def test_verified_library_is_not_rebuilt(cached):
    cache, library, digest = cached
    before = library.stat().st_mtime_ns, library.stat().st_ino
    assert _child(cache) == (library, digest)
    assert (library.stat().st_mtime_ns, library.stat().st_ino) == before


@pytest.mark.parametrize("cc", ["{cc} -O0", "env {cc}", "  {cc}  "])
def test_cc_with_arguments_is_split_into_words(compiled, tmp_path, cc):
    """As make passes $(CC) to the shell: 'ccache gcc' and 'gcc -O0' are commands."""
    import shutil

    compiler = shutil.which("cc") or shutil.which("gcc")
    command = cc.format(cc=compiler)
    library, digest = _child(tmp_path, CC=command)
    plain, plain_digest = _child(tmp_path / "plain", CC=compiler)
    assert library.exists()
    if command.strip() == compiler:
        assert library.name == plain.name  # surrounding blanks do not change the key
    else:
        assert library.name != plain.name  # the command is part of the key
    assert digest == plain_digest  # -O3 comes later on the command line and wins


def test_unparsable_cc_falls_back_to_numpy_and_says_why(tmp_path):
    import os
    import subprocess
    import sys

    code = (
        "from vsw.models.ile import kernels; print(kernels.library() is None, kernels.build_error)"
    )
    env = {**os.environ, "VSW_CACHE_DIR": str(tmp_path), "CC": "gcc 'unbalanced"}
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert done.stdout.startswith("True compiled kernels unavailable, using numpy: CC=")


def test_concurrent_first_builds_agree(compiled, tmp_path):
    """Processes building into one empty cache at once: each loads a complete library, and
    the cache ends with one library whose sidecar describes it."""
    import hashlib
    import json
    import os
    import subprocess
    import sys

    env = {**os.environ, "VSW_CACHE_DIR": str(tmp_path), "VSW_KERNELS": "1"}
    runs = [
        subprocess.Popen(
            [sys.executable, "-c", CHILD], cwd=ROOT, env=env, stdout=subprocess.PIPE, text=True
        )
        for _ in range(3)
    ]
    outputs = [run.communicate(timeout=300)[0].split() for run in runs]
    assert [run.returncode for run in runs] == [0, 0, 0]
    assert len({tuple(out) for out in outputs}) == 1 and outputs[0][0] == "None"
    (library,) = tmp_path.glob("*.so")
    record = json.loads(library.with_name(library.name + ".json").read_text())
    assert record["sha256"] == hashlib.sha256(library.read_bytes()).hexdigest()
    assert not list(tmp_path.glob(".build-*"))
