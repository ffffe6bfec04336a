#!/usr/bin/env python3
"""A before-and-after check on a lent GPU, in one device run (docs/performance.md, "On a
real GPU"). It drives the kit of ../shared/device/ (its check.py's sections) for two builds
on the same machine, measures Mitsuba 3 once, and runs this repository's GPU test suites
there. A lease has 15 minutes in all, start included: prepare everything here first.

Here, from the repository's root (builds HEAD and BASE, about 10 minutes on 2 cores):

    python3 scripts/device_check.py prepare BASE

Then one device run, `carry: [".device-kit"]`, `timeout_s` 600:

    python3 .device-kit/device_check.py run

In that run, within LIMIT seconds (545 unless $LIMIT says otherwise), in this order:
HEAD's adapter, speed, samples and course sections; `compare` over scenes/hard and
`selftest`; `-v`'s split at each tile size and with 1 to 4 tiles in flight, a 16² render
and the bytes' own write time (probe); both builds' whole process minus a 16² run,
interleaved, with `-v`'s split; the base's sections but course; `bench`'s warm and moving
frames (bunny_40k, and scene2_10 at 1920×1080); then the test suites for as long as time
is left. Each build's pass starts with empty caches (a fresh HOME and XDG_CACHE_HOME: the
driver's and ours). $OUT receives log.txt, results.json, bench.csv, bench_live.csv and
tests.log.
"""
import glob, json, os, shutil, statistics, subprocess, sys, time

KIT = '.device-kit'
TESTS = ['hard_cases', 'precision', 'ray_tree', 'solid_textures', 'parity', 'drivers', 'present', 'tiles', 'aim',
         'renderer', 'analytic_shading', 'bvh', 'conformance', 'fused_mode', 'loop_limit', 'pipeline_cache',
         'scaled_and_moved_scenes', 'spawn_gap', 'split', 'supersampling', 'shared_kernels', 'phong_against_course',
         'shadows_reflections_against_course', 'grids_against_reference', 'random_scenes']


def prepare(base):
    sh = lambda cmd, **kw: subprocess.run(cmd, shell=True, check=True, **kw)
    sh('bash ../shared/device/prepare.sh')
    work, target = '/tmp/device_check_base', '/tmp/device_check_base_target'
    sh(f'git worktree remove --force {work} 2>/dev/null; git worktree add -f {work} {base}')
    sh(f'cd {work} && CARGO_TARGET_DIR={target} cargo build --release -q')
    sh(f'xz -T0 -6 -c {target}/release/raycaster > {KIT}/raycaster_base.xz')
    sh(f"for l in $(ldd {target}/release/raycaster | awk '/=> \\// {{print $3}}' | grep -v -E "
       f"'/(libc|libm|libgcc_s|libpthread|libdl|librt|ld-linux[^/]*)\\.so'); do cp -L $l {KIT}/lib/; done")
    out = subprocess.run(['cargo', 'test', '--release', '--no-run', '--message-format=json'],
                         capture_output=True, text=True, check=True).stdout
    binaries = {}
    for line in out.splitlines():
        m = json.loads(line)
        if m.get('reason') == 'compiler-artifact' and m.get('executable') and m['profile']['test']:
            name = 'raycaster' if m['target']['kind'] == ['lib'] else m['target']['name']
            if name in TESTS or name == 'raycaster':
                binaries[name] = m['executable']
    staging = '/tmp/device_check_tests'
    shutil.rmtree(staging, ignore_errors=True)
    os.makedirs(staging)
    for name, path in binaries.items():
        shutil.copy(path, os.path.join(staging, name))
    sh(f'tar -C {staging} -cf - . | xz -T2 -9e > {KIT}/tests.tar.xz')
    shutil.copy(__file__, KIT)
    tree = int(subprocess.run("git ls-files -z | xargs -0 du -cb | tail -1 | cut -f1", shell=True,
                              capture_output=True, text=True).stdout or 0)
    kit = int(subprocess.run(['du', '-sb', KIT], capture_output=True, text=True).stdout.split()[0])
    print(f'prepared: {len(binaries)} test binaries; kit {kit / 2**20:.1f} MiB + tree {tree / 2**20:.1f} MiB '
          f'(at most 64 MiB travel)')
    if kit + tree > 63 << 20:
        sys.exit('too large to travel: leave out some test suites (TESTS)')


def set_up():
    """What ../shared/device/run.sh does before check.py: the driver's loader, both
    binaries and Mitsuba unpacked under /tmp/k."""
    for deb in glob.glob(f'{KIT}/gl/*.deb'):
        subprocess.run(['dpkg', '-x', deb, '/'], check=True)
    subprocess.run(['ldconfig'], check=True)
    icd = '/usr/local/nvidia/share/vulkan/icd.d/nvidia_icd.json'
    if os.path.exists(icd):
        os.environ['VK_DRIVER_FILES'] = icd
    os.makedirs('/tmp/k/site', exist_ok=True)
    import lzma, tarfile
    for src, dst in [('raycaster.xz', 'raycaster'), ('raycaster_base.xz', 'raycaster_base')]:
        with lzma.open(f'{KIT}/{src}') as s, open(f'/tmp/k/{dst}', 'wb') as d:
            shutil.copyfileobj(s, d)
        os.chmod(f'/tmp/k/{dst}', 0o755)
    tarfile.open(f'{KIT}/mitsuba-3.9.1-cuda-cp312.tar.xz').extractall('/tmp/k/site')
    lib = os.path.abspath(f'{KIT}/lib')
    os.environ.update(LD_LIBRARY_PATH=lib + (':' + os.environ['LD_LIBRARY_PATH'] if 'LD_LIBRARY_PATH' in os.environ else ''),
                      PYTHONUNBUFFERED='1', XDG_RUNTIME_DIR='/tmp')
    # The test binaries name this checkout's path here (CARGO_MANIFEST_DIR) and the binary
    # under target/release.
    root = os.getcwd()
    if root != '/work/main' and not os.path.exists('/work/main'):
        os.makedirs('/work', exist_ok=True)
        os.symlink(root, '/work/main')
    os.makedirs('target/release', exist_ok=True)
    shutil.copy('/tmp/k/raycaster', 'target/release/raycaster')


def run():
    set_up()
    if shutil.which('nvidia-smi'):
        subprocess.run(['nvidia-smi', '--query-gpu=name,driver_version,memory.total', '--format=csv,noheader'])
    sys.path.insert(0, os.path.abspath(KIT))
    import check
    out = check.OUT
    os.makedirs(out, exist_ok=True)
    limit = float(os.environ.get('LIMIT', '545'))
    left = lambda: limit - (time.time() - check.T0)
    measured = {}
    mitsuba = check.mitsuba

    def mitsuba_once(cases):
        if tuple(cases) not in measured:
            measured[tuple(cases)] = mitsuba(cases)
        return measured[tuple(cases)]

    check.mitsuba = mitsuba_once
    results = {}

    def save():
        json.dump(results, open(os.path.join(out, 'results.json'), 'w'), indent=1, default=str)

    def fresh_pass(tag, binary):
        home = f'/tmp/k/home_{tag}'
        os.makedirs(home, exist_ok=True)
        os.environ.update(HOME=home, XDG_CACHE_HOME=home + '/.cache')
        for folder in glob.glob('/tmp/k/course_*'):
            shutil.rmtree(folder)
        check.BIN = binary
        check.RESULTS = {}

    def section(name, need, fn):
        if left() < need:
            check.log(f'skipped {name}: {left():.0f} s left, it needs {need}')
            return
        check.log(f'=== {name} ({check.BIN})')
        try:
            fn()
        except Exception as e:  # each section stands alone, as in check.py
            check.log(f'{name} failed: {type(e).__name__}: {str(e)[:400]}')

    def shell(cmd, timeout, log_name=None):
        t = time.perf_counter()
        try:
            p = subprocess.run(cmd, shell=True, capture_output=True, text=True, timeout=max(timeout, 1))
            text, rc = p.stdout + p.stderr, p.returncode
        except subprocess.TimeoutExpired as e:
            text, rc = (e.stdout or b'').decode(errors='replace') if isinstance(e.stdout, bytes) else (e.stdout or ''), 'timeout'
        if log_name:
            with open(os.path.join(out, log_name), 'a') as f:
                f.write(f'$ {cmd}\n{text}\nrc={rc} in {time.perf_counter() - t:.1f} s\n')
        return rc, text

    def hard_and_selftest():
        check.hard()
        rc, text = shell(f'{check.BIN} selftest', 90)
        check.log(f'selftest exit {rc}:\n{text[-3000:]}')

    def pairs():
        """Both builds in turn, the whole process at each size minus a 16² run just before
        it, and `-v`'s split of one more render."""
        w = check.bunny()
        one = lambda b, s, *v: check.run([b, *v, '-input', 'b.txt', '-size', str(s), str(s), '-output', 'o.tga',
                                          '--backend', 'gpu'], w)
        builds = {'after': '/tmp/k/raycaster', 'before': '/tmp/k/raycaster_base'}
        small = {b: [] for b in builds}
        for size in [2048, 4096, 8192]:
            diffs = {b: [] for b in builds}
            for _ in range(5 if size < 8192 else 3):
                for b, path in builds.items():
                    a, _ = one(path, 16)
                    t, _ = one(path, size)
                    small[b].append(a)
                    diffs[b].append(t - a)
            for b, path in builds.items():
                _, p = one(path, size, '-v')
                check.log(f'pairs {size}² {b}: whole minus 16², median {statistics.median(diffs[b]) * 1e3:.1f} ms '
                          f'(all: {[round(d * 1e3) for d in diffs[b]]}); {check.vlines(p.stderr)}')
            results.setdefault('pairs', {})[size] = {b: statistics.median(v) for b, v in diffs.items()}
        for b in builds:
            check.log(f'pairs: a 16² render, whole process, {b}: median {statistics.median(small[b]) * 1e3:.0f} ms')

    def probe():
        """Where a render's time goes on this adapter: `-v`'s split (the kernel compiled
        beside the upload, waiting for tiles, the later tiles' lists) at each tile size
        RAYCASTER_TILE_MIB offers and with 1 to 4 tiles in flight (RAYCASTER_TILE_SLOTS),
        the whole process of a 16² render, and the time the same bytes take to write from
        Python (goal 1's yardstick)."""
        w = check.bunny()
        # Tile sizes, then tiles in flight at the adapter's own tile: with more in flight the
        # device renders the next tiles while the renderer's thread waits for one.
        settings = [('RAYCASTER_TILE_MIB', mib, f'tiles of {mib} MiB') for mib in [1, 2, 4, 8, 32]]
        settings += [('RAYCASTER_TILE_SLOTS', n, f'{n} in flight') for n in [1, 2, 3, 4]]
        for size in [2048, 8192]:
            for variable, value, said in settings:
                env = dict(os.environ, **{variable: str(value)})
                runs = [check.run([check.BIN, '-v', '-input', 'b.txt', '-size', str(size), str(size), '-output',
                                   'o.tga', '--backend', 'gpu'], w, env=env) for _ in range(3)]
                whole = statistics.median(t for t, _ in runs)
                check.log(f'probe {size}² {said}: whole {whole * 1e3:.1f} ms; {check.vlines(runs[-1][1].stderr)}')
                results.setdefault('probe', {})[f'{size}/{variable}={value}'] = whole
        small = [check.run([check.BIN, '-input', 'b.txt', '-size', '16', '16', '-output', 'o.tga', '--backend',
                            'gpu'], w)[0] for _ in range(9)]
        check.log(f'probe: a 16² render, whole process: median {statistics.median(small) * 1e3:.1f} ms '
                  f'(all: {[round(t * 1e3) for t in small]})')
        for size in [2048, 8192]:
            data = bytes(18 + 3 * size * size)
            times = []
            for _ in range(5):
                t = time.perf_counter()
                with open(os.path.join(w, 'raw.bin'), 'wb') as f:
                    f.write(data)
                times.append(time.perf_counter() - t)
                os.remove(os.path.join(w, 'raw.bin'))
            check.log(f'probe: writing the {size}² TGA\'s {len(data)} bytes from Python: median '
                      f'{statistics.median(times) * 1e3:.1f} ms (all: {[round(t * 1e3) for t in times]})')
        # The TGA writer alone: `stitch` of one part of the whole 8192² image (RGB rows in,
        # the TGA out), the part copied back before each run since stitch removes it.
        check.run([check.BIN, '-input', 'b.txt', '-size', '8192', '8192', '-output', 'p.tga', '--tile', '0/1',
                   '--backend', 'gpu'], w)
        part = os.path.join(w, 'p.tga.part-0-of-1')
        if os.path.exists(part):
            os.replace(part, part + '.keep')
            times = []
            for _ in range(3):
                shutil.copy(part + '.keep', part)
                times.append(check.run([check.BIN, 'stitch', '-output', 'p.tga'], w)[0])
            check.log(f'probe: stitch of the 8192² part into a TGA: median {statistics.median(times) * 1e3:.1f} ms '
                      f'(all: {[round(t * 1e3) for t in times]})')

    def bench():
        # bunny_40k's sizes, then a course scene at the live view's 1920×1080 (its moving
        # frames drawn on the device: the window's frame, with no display here).
        for only, csv, cap in [('bunny_40k', 'bench.csv', 60), ('scene2_10', 'bench_live.csv', 30)]:
            rc, text = shell(f'{check.BIN} bench --only {only} --runs 7 --corpus {KIT}/mit6837 '
                             f'--out /tmp/k/bench_{only}', min(cap, left() - 20))
            check.log(f'bench --only {only} exit {rc}:\n{text[-6000:]}')
            if os.path.exists(f'/tmp/k/bench_{only}/bench.csv'):
                shutil.copy(f'/tmp/k/bench_{only}/bench.csv', os.path.join(out, csv))

    def tests():
        folder = '/tmp/k/tests'
        os.makedirs(folder, exist_ok=True)
        shell(f'tar -xJf {KIT}/tests.tar.xz -C {folder}', 60)
        corpus = os.path.abspath(f'{KIT}/mit6837')
        for name in [t for t in TESTS + ['raycaster'] if os.path.exists(os.path.join(folder, t))]:
            if left() < 15:
                check.log(f'tests: stopped before {name}, {left():.0f} s left')
                break
            cap = int(left() - 5)
            rc, text = shell(f'cd /work/main && RAYCASTER_CORPUS={corpus} timeout {cap} {folder}/{name} '
                             f'--test-threads 4 2>&1', cap + 5, 'tests.log')
            summary = [l for l in text.splitlines() if l.startswith('test result') or 'FAILED' in l or 'panicked' in l]
            check.log(f'tests {name}: exit {rc} ' + ' | '.join(summary[:8]))

    check.log(f'limit {limit:.0f} s')
    for tag, binary, after in [('after', '/tmp/k/raycaster', True), ('before', '/tmp/k/raycaster_base', False)]:
        fresh_pass(tag, binary)
        # The base's course images were checked on an earlier lease: its time goes to the tests.
        for name, need in [('adapter', 10), ('speed', 60), ('samples', 60), ('course', 80)][:4 if after else 3]:
            section(name, need, getattr(check, name))
        results[tag] = check.RESULTS
        save()
        if after:
            section('hard and selftest', 40, hard_and_selftest)
            section('probe', 60, probe)
            section('pairs', 150, pairs)
    check.BIN = '/tmp/k/raycaster'
    section('bench', 60, bench)
    section('tests', 30, tests)
    save()
    check.log('done')


if __name__ == '__main__':
    if sys.argv[1:2] == ['prepare'] and len(sys.argv) == 3:
        prepare(sys.argv[2])
    elif sys.argv[1:] == ['run']:
        run()
    else:
        sys.exit(__doc__)
