#!/usr/bin/env python3
"""The compare-builds check: two raycaster binaries render the same jobs, and every file
they write must be identical: byte for byte, except PNG files, which must decode to the same
pixels (8-bit RGB, the only PNG the program writes), and ZIP-compressed EXR files, which must
hold the same headers and the same floats bit for bit. Their compressed bytes depend on how
the image data is deflated (by which library, at a level chosen by measurement), which
changes nothing a reader sees.

    scripts/compare_builds.py BIN_A BIN_B [--course DIR] [--size N] [--work DIR]

The jobs: every line of the course's assignments' commands.txt (a2 .. a7), through
`raycaster batch commands.txt --backend gpu` and `--backend cpu`, each in a fresh copy of
its folder; and every scenes/*.txt and scenes/hard/*.txt of this repository, rendered at
N x N (64 unless told) with -output, -normals and -depth (an .exr, the distance itself)
on both backends. A scene that does not load is a job too: both builds must refuse it
alike (the exit codes are compared, not the messages, which may name timings).

A binary's outputs are kept under --work, named by the digest of its bytes, so the
baseline is rendered once however often the check runs.
"""

import argparse
import hashlib
import json
import shutil
import struct
import subprocess
import sys
import zlib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
ASSIGNMENTS = ["a2", "a3", "a4", "a5", "a6", "a7"]
BACKENDS = ["gpu", "cpu"]


def digest(path):
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()[:16]


def run(command, cwd, log):
    with open(log, "wb") as out:
        done = subprocess.run(command, cwd=cwd, stdout=out, stderr=subprocess.STDOUT)
    return done.returncode


def scenes():
    found = sorted((ROOT / "scenes").glob("*.txt")) + sorted((ROOT / "scenes" / "hard").glob("*.txt"))
    return [p for p in found if p.name != "README.txt"]


def render_all(binary, course, size, out):
    """Renders every job with `binary` into `out`; returns {job: exit code}."""
    codes = {}
    for backend in BACKENDS:
        for assignment in ASSIGNMENTS:
            folder = out / backend / assignment
            shutil.copytree(course / assignment, folder)
            # Scenes name meshes beside them or in the course's shared folder.
            if (course / "meshes").is_dir() and not (out / backend / "meshes").exists():
                shutil.copytree(course / "meshes", out / backend / "meshes")
            command = [str(binary), "batch", "commands.txt", "--backend", backend]
            codes[f"{backend}/{assignment}"] = run(command, folder, out / backend / f"{assignment}.log")
        for scene in scenes():
            name = scene.relative_to(ROOT / "scenes").with_suffix("").as_posix().replace("/", "__")
            folder = out / backend / "scenes" / name
            folder.mkdir(parents=True)
            command = [str(binary), "-input", str(scene), "-size", str(size), str(size),
                       "-output", "x.png", "-normals", "n.png", "-depth", "0", "20", "d.exr",
                       "--backend", backend]
            codes[f"{backend}/scenes/{name}"] = run(command, folder, folder.parent / f"{name}.log")
    return codes


def outputs(binary, course, size, work):
    """The folder of `binary`'s outputs, rendered unless an earlier run left them complete."""
    out = work / f"{digest(binary)}-{size}"
    done = out / "exit_codes.json"
    if not done.exists():
        if out.exists():
            shutil.rmtree(out)
        out.mkdir(parents=True)
        codes = render_all(Path(binary).resolve(), course, size, out)
        done.write_text(json.dumps(codes, indent=1, sort_keys=True))
    return out, json.loads(done.read_text())


def png_pixels(data):
    """The rows of an 8-bit RGB PNG, unfiltered (PNG specification §9), or None if `data`
    is no such PNG. zlib checks the stream's Adler-32; every chunk's CRC is checked here."""
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        return None
    pos, header, idat = 8, None, []
    while pos + 12 <= len(data):
        (length,) = struct.unpack(">I", data[pos:pos + 4])
        kind, body = data[pos + 4:pos + 8], data[pos + 8:pos + 8 + length]
        (crc,) = struct.unpack(">I", data[pos + 8 + length:pos + 12 + length])
        if zlib.crc32(kind + body) != crc:
            return None
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat.append(body)
        pos += 12 + length
    if header is None or header[2:] != (8, 2, 0, 0, 0):
        return None
    width, height = header[:2]
    raw = zlib.decompress(b"".join(idat))
    stride, bpp = width * 3, 3
    rows, prior = [], bytearray(stride)
    for y in range(height):
        kind, line = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for x in range(stride):
            a = line[x - bpp] if x >= bpp else 0
            b = prior[x]
            c = prior[x - bpp] if x >= bpp else 0
            if kind == 1:
                line[x] = (line[x] + a) & 255
            elif kind == 2:
                line[x] = (line[x] + b) & 255
            elif kind == 3:
                line[x] = (line[x] + (a + b) // 2) & 255
            elif kind == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[x] = (line[x] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append(bytes(line))
        prior = line
    return (width, height, b"".join(rows))


def exr_blocks(data):
    """The header and the raw little-endian bytes of each block, by y, of a single-part
    scan-line OpenEXR file whose blocks are ZIP or ZIPS compressed (or stored), or None if
    `data` is no such file. OpenEXR's `Zip::uncompress`: inflate, add each byte to the one
    before less 128, then interleave the two halves. A block whose size is the raw size's
    is stored as it is, which is why the raw sizes are worked out from the header."""
    if data[:4] != b"\x76\x2f\x31\x01" or data[4] != 2 or data[5:8] != b"\0\0\0":
        return None
    pos, attributes = 8, {}
    while data[pos] != 0:
        name_end = data.index(b"\0", pos)
        kind_end = data.index(b"\0", name_end + 1)
        (size,) = struct.unpack("<i", data[kind_end + 1:kind_end + 5])
        attributes[data[pos:name_end]] = data[kind_end + 5:kind_end + 5 + size]
        pos = kind_end + 5 + size
    header_end = pos + 1
    compression = attributes[b"compression"][0]
    if compression not in (0, 2, 3):
        return None
    x0, y0, x1, y1 = struct.unpack("<4i", attributes[b"dataWindow"])
    pixel_bytes, channels = 0, attributes[b"channels"]
    while channels[0] != 0:
        name_end = channels.index(b"\0")
        (kind,) = struct.unpack("<i", channels[name_end + 1:name_end + 5])
        pixel_bytes += 2 if kind == 1 else 4
        channels = channels[name_end + 17:]
    lines = {0: 1, 2: 1, 3: 16}[compression]
    blocks = (y1 - y0 + lines) // lines
    offsets = struct.unpack(f"<{blocks}Q", data[header_end:header_end + 8 * blocks])
    raw = {}
    for offset in offsets:
        y, size = struct.unpack("<iI", data[offset:offset + 8])
        block = data[offset + 8:offset + 8 + size]
        expected = (x1 - x0 + 1) * pixel_bytes * (min(y + lines, y1 + 1) - y)
        if size < expected:
            predicted = bytearray(zlib.decompress(block))
            for k in range(1, len(predicted)):
                predicted[k] = (predicted[k - 1] + predicted[k] - 128) & 255
            half = (len(predicted) + 1) // 2
            block = bytearray(len(predicted))
            block[0::2], block[1::2] = predicted[:half], predicted[half:]
        raw[y] = bytes(block)
    return data[:header_end], raw


def same_file(path_a, path_b):
    """Byte for byte; PNG files the same decoded pixels; EXR files the same header and
    blocks once inflated."""
    data_a, data_b = path_a.read_bytes(), path_b.read_bytes()
    if data_a == data_b:
        return True
    suffix = path_a.suffix.lower()
    decode = png_pixels if suffix == ".png" else exr_blocks if suffix == ".exr" else None
    if decode is None:
        return False
    decoded_a = decode(data_a)
    return decoded_a is not None and decoded_a == decode(data_b)


def written_files(root, course):
    """Every file a job wrote: those under `root` but its logs, its bookkeeping and the
    copies of the course's own files."""
    inputs = {p.relative_to(course).as_posix() for p in course.rglob("*") if p.is_file()}
    found = set()
    for path in root.rglob("*"):
        if not path.is_file() or path.suffix == ".log" or path.name == "exit_codes.json":
            continue
        relative = path.relative_to(root).as_posix()
        backend, _, rest = relative.partition("/")
        if rest in inputs:
            continue
        found.add(relative)
    return found


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("bin_a")
    parser.add_argument("bin_b")
    parser.add_argument("--course", type=Path, default=ROOT / ".." / "shared" / "mit6837")
    parser.add_argument("--size", type=int, default=64)
    parser.add_argument("--work", type=Path, default=Path("/tmp/compare_builds"))
    args = parser.parse_args()
    course = args.course.resolve()
    if not (course / "a2" / "commands.txt").exists():
        sys.exit(f"no course at {course} (--course DIR)")
    (a, codes_a), (b, codes_b) = (outputs(x, course, args.size, args.work) for x in (args.bin_a, args.bin_b))
    files_a, files_b = written_files(a, course), written_files(b, course)
    identical, different = 0, []
    for name in sorted(files_a & files_b):
        if same_file(a / name, b / name):
            identical += 1
        else:
            different.append(name)
    only_a, only_b = sorted(files_a - files_b), sorted(files_b - files_a)
    codes_differ = sorted(job for job in codes_a.keys() | codes_b.keys() if codes_a.get(job) != codes_b.get(job))
    total = len(files_a | files_b)
    for label, names in [("differ", different), (f"only from {args.bin_a}", only_a),
                         (f"only from {args.bin_b}", only_b), ("exit codes differ", codes_differ)]:
        for name in names:
            print(f"{label}: {name}")
    failed = sum(1 for code in codes_a.values() if code != 0)
    print(f"{len(codes_a)} jobs ({failed} refused alike or failed alike)" if not codes_differ
          else f"{len(codes_differ)} of {len(codes_a)} jobs exit differently")
    print(f"{identical} of {total} files identical (PNG files: the same decoded pixels; EXR: the same floats)")
    sys.exit(0 if identical == total and not codes_differ and total > 0 else 1)


if __name__ == "__main__":
    main()
