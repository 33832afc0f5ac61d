"""What a user installs: the licence, and every page the README links to, ship in the source distribution."""

from __future__ import annotations

import re
import shutil
import subprocess
import sys
import tarfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]


def _readme_relative_links() -> set[str]:
    text = (REPO / "README.md").read_text()
    targets = re.findall(r"\]\(([^)#\s]+)", text)
    return {t for t in targets if not re.match(r"[a-z]+://", t)}


def test_readme_links_point_to_files_of_the_repository():
    links = _readme_relative_links()
    assert links, "the README links no page: this test would check nothing"
    missing = sorted(t for t in links if not (REPO / t).is_file())
    assert not missing, f"README links to missing files: {missing}"


def _clean_copy(dest: Path) -> Path:
    """The files of a fresh clone (git's tracked and new, unignored files): no egg-info of earlier builds."""
    listed = subprocess.run(["git", "ls-files", "--cached", "--others", "--exclude-standard"], cwd=REPO,
                            capture_output=True, text=True, check=True).stdout.splitlines()
    for name in listed:
        src = REPO / name
        if src.is_file():
            (dest / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(src, dest / name)
    return dest


def test_sdist_carries_the_licence_and_every_page_the_readme_links(tmp_path):
    src = _clean_copy(tmp_path / "src")
    code = "import sys, setuptools.build_meta as b; print(b.build_sdist(sys.argv[1]))"
    done = subprocess.run([sys.executable, "-c", code, str(tmp_path)], cwd=src, capture_output=True, text=True)
    assert done.returncode == 0, done.stderr[-2000:]
    archive = tmp_path / done.stdout.strip().splitlines()[-1]
    with tarfile.open(archive) as tar:
        names = {name.split("/", 1)[1] for name in tar.getnames() if "/" in name}
    wanted = {"LICENSE", "README.md", *_readme_relative_links()}
    assert not wanted - names, f"not in the sdist: {sorted(wanted - names)}"
    assert "BSD 3-Clause" in (REPO / "LICENSE").read_text()
