"""Peak memory of ``rcb cam depthmap`` refusing images too large to decode (issue 29, item 4).

A 1.86 MB 16-bit TIFF of 30000^2 pixels went past 8.2 GB before this check; a 164 kB PNG of
13000^2 reached 1.54 GB. The images are written here without holding their pixels (one grey
level: a PNG's rows deflated one at a time, a TIFF's strips all pointing at one deflated row),
and each is handed to the ``rcb`` executable in its own process, whose peak resident memory
(``ru_maxrss`` from ``os.wait4``) is printed; the target is under 200 MB. A missing file's
refusal is the baseline: what starting ``rcb cam depthmap`` costs before any image is read.

    .venv/bin/python benchmarks/depthmap_bombs.py
"""

from __future__ import annotations

import struct
import subprocess
import sys
import tempfile
import zlib
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PLAN = ROOT / "examples" / "cam_relief_part.toml"
RCB = Path(sys.executable).with_name("rcb")
#: The most a refusal may take [MB] (issue 29's acceptance).
TARGET_MB = 200.0

_PNG = b"\x89PNG\r\n\x1a\n"


def _chunk(kind: bytes, data: bytes) -> bytes:
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(kind + data))


def png_of_one_grey(path: Path, side: int, bits: int = 8) -> Path:
    """A ``side`` x ``side`` greyscale PNG (8 or 16 bits), every pixel 0."""
    header = struct.pack(">IIBBBBB", side, side, bits, 0, 0, 0, 0)
    row = b"\x00" * (1 + side * bits // 8)  # filter type 0, then the row's pixels
    deflate = zlib.compressobj(9)
    data = b"".join(deflate.compress(row) for _ in range(side)) + deflate.flush()
    path.write_bytes(_PNG + _chunk(b"IHDR", header) + _chunk(b"IDAT", data) + _chunk(b"IEND", b""))
    return path


def tiff_of_one_grey(path: Path, side: int, bits: int = 16) -> Path:
    """A ``side`` x ``side`` greyscale TIFF (little-endian, deflate), every pixel 0."""
    strip = zlib.compress(b"\x00" * (side * bits // 8), 9)  # one row a strip, all the same
    entries = 10
    ifd_at = 8
    ifd_size = 2 + entries * 12 + 4
    offsets_at = ifd_at + ifd_size
    counts_at = offsets_at + 4 * side
    strip_at = counts_at + 4 * side
    tags = [
        (256, 4, 1, side),  # ImageWidth
        (257, 4, 1, side),  # ImageLength
        (258, 3, 1, bits),  # BitsPerSample
        (259, 3, 1, 8),  # Compression: deflate
        (262, 3, 1, 1),  # PhotometricInterpretation: black is zero
        (273, 4, side, offsets_at),  # StripOffsets
        (277, 3, 1, 1),  # SamplesPerPixel
        (278, 4, 1, 1),  # RowsPerStrip
        (279, 4, side, counts_at),  # StripByteCounts
        (284, 3, 1, 1),  # PlanarConfiguration: contiguous
    ]
    ifd = struct.pack("<H", entries)
    for tag, kind, count, value in tags:
        packed = struct.pack("<HH", value, 0) if kind == 3 else struct.pack("<I", value)
        ifd += struct.pack("<HHI", tag, kind, count) + packed
    ifd += struct.pack("<I", 0)
    body = struct.pack(f"<{side}I", *([strip_at] * side))
    body += struct.pack(f"<{side}I", *([len(strip)] * side))
    path.write_bytes(b"II*\x00" + struct.pack("<I", ifd_at) + ifd + body + strip)
    return path


@dataclass(frozen=True)
class Refusal:
    """What ``rcb cam depthmap IMAGE`` did: its exit code, its stderr and its peak memory."""

    exit_code: int
    stderr: str
    peak_mb: float


#: Forks and runs ``argv[2:]`` with ``RLIMIT_AS`` ``argv[1]`` (0: none) and writes its child's
#: ``ru_maxrss`` [kB] to stdout. Linux keeps the high-water mark of the memory a process had
#: when it called ``exec`` (``sig->maxrss``): a child forked by a large process (a pytest worker
#: of 400 MB) reports the parent's size. Forked from this small launcher it reports its own.
_LAUNCHER = """
import os, resource, sys
cap = int(sys.argv[1])
pid = os.fork()
if pid == 0:
    if cap:
        resource.setrlimit(resource.RLIMIT_AS, (cap, cap))
    os.execv(sys.argv[2], sys.argv[2:])
_, status, usage = os.wait4(pid, 0)
sys.stdout.write(str(usage.ru_maxrss))
sys.exit(os.waitstatus_to_exitcode(status))
"""


def refuse(image: Path, out_dir: Path, address_space: int | None = None) -> Refusal:
    """Run ``rcb cam depthmap IMAGE`` in its own process; its peak RSS from ``wait4``.

    ``address_space``: a cap on the child's virtual memory [bytes] (``RLIMIT_AS``), so that a
    decode that should not happen fails at once instead of filling the machine's memory. The
    child is forked by a small launcher (:data:`_LAUNCHER`), whatever the caller's size.
    """
    args = [str(RCB), "cam", "depthmap", str(image), "--pixel-mm", "0.1"]
    args += ["--z-range-mm", "0:20", "--tool", "flat:10", "--plan", str(PLAN)]
    args += ["--operation", "rough", "--out", str(out_dir / "p.nc")]
    launcher = [sys.executable, "-S", "-c", _LAUNCHER, str(address_space or 0), *args]
    done = subprocess.run(launcher, capture_output=True, check=False)
    text = done.stderr.decode("utf-8", "replace")
    peak_kb = float(done.stdout.decode() or "nan")
    return Refusal(done.returncode, text, peak_kb / 1024)  # Linux: kB


def cases(folder: Path) -> dict[str, Path]:
    """The images of the issue, written into ``folder``, and a missing file (the baseline)."""
    return {
        "missing file (baseline)": folder / "missing.png",
        "TIFF 30000^2 16-bit": tiff_of_one_grey(folder / "t16.tif", 30000, 16),
        "TIFF 30000^2 8-bit": tiff_of_one_grey(folder / "t8.tif", 30000, 8),
        "PNG 13000^2 8-bit": png_of_one_grey(folder / "p8.png", 13000, 8),
        "PNG 30000^2 16-bit": png_of_one_grey(folder / "p16.png", 30000, 16),
    }


def main() -> int:
    """Print each refusal's peak memory; exit 1 when one is over the target or not refused."""
    failed = False
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        print(f"{'image':26} {'on disk':>10} {'exit':>4} {'peak MB':>8}")
        for name, image in cases(folder).items():
            size = f"{image.stat().st_size / 1e3:.0f} kB" if image.exists() else "-"
            result = refuse(image, folder)
            print(f"{name:26} {size:>10} {result.exit_code:>4} {result.peak_mb:>8.1f}")
            failed |= result.exit_code != 2 or result.peak_mb > TARGET_MB
    print(f"target: every refusal exit 2, under {TARGET_MB:.0f} MB peak")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
