//! `grade --run` against hostile students (docs/grading.md, "What a student's program can and
//! cannot do"): each test is a program that tries one attack, and asserts both the grader's
//! verdict and that nothing leaked, survived or was written outside. Where the attack would
//! succeed without the sandbox, the test shows that too, with `--no-sandbox`. Legitimate
//! programs (a compiled C++ one, a Python script with numpy and Pillow, our own binary) still
//! pass. Needs no course files: the assignment is made of our own scenes.
//!
//! They need bubblewrap (`bwrap`), which CI installs; without it they fail, loudly, unless
//! `RAYCASTER_SKIP_SANDBOX=1` says to skip them on purpose.
#![cfg(target_os = "linux")]

mod common;

use common::bin::{command, path_str, report_line, stderr, stdout};
use std::os::unix::fs::PermissionsExt;
use std::path::{Path, PathBuf};
use std::process::Output;
use std::time::{Duration, Instant};

/// The lines of the assignment: three lines, four images, a mesh, and the course's preview
/// flags on line 2.
const COMMANDS: &str = "\
-input spheres_ortho.txt -size 64 64 -output out1.tga
-input mesh_octahedron.txt -size 48 40 -output out2.tga -normals out2n.tga -gui -tessellation 10 5 -gouraud
-input spheres_ortho.txt -size 32 32 -output out3.tga
";

/// An assignment, a student's folder (their program, a copy of our binary beside it to
/// render with) and a folder of the teacher's with a secret in it, all readable by the
/// user `nobody` (grade run as root runs the sandbox as that user).
struct Class {
    _root: tempfile::TempDir,
    assignment: PathBuf,
    student: PathBuf,
    teacher: PathBuf,
    secret: PathBuf,
}

const SECRET: &str = "the-teachers-secret-3141";

fn class() -> Option<Class> {
    if std::env::var("RAYCASTER_SKIP_SANDBOX").as_deref() == Ok("1") {
        return None;
    }
    assert!(
        Path::new("/usr/bin/bwrap").exists() || which("bwrap"),
        "grade's sandbox needs bubblewrap: apt-get install bubblewrap (or RAYCASTER_SKIP_SANDBOX=1 to skip on purpose)"
    );
    let root = tempfile::tempdir().unwrap();
    let folder = |name: &str| {
        let dir = root.path().join(name);
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::set_permissions(&dir, std::fs::Permissions::from_mode(0o755)).unwrap();
        dir
    };
    std::fs::set_permissions(root.path(), std::fs::Permissions::from_mode(0o755)).unwrap();
    let (assignment, student, teacher) = (folder("a9"), folder("student"), folder("teacher"));
    for file in ["spheres_ortho.txt", "mesh_octahedron.txt", "octahedron.obj"] {
        std::fs::copy(common::scenes_dir().join(file), assignment.join(file)).unwrap();
    }
    std::fs::write(assignment.join("commands.txt"), COMMANDS).unwrap();
    // The course's own image of line 1 (ours, so that a copy of it would pass).
    std::fs::create_dir(assignment.join("expected")).unwrap();
    render(&assignment, "-input spheres_ortho.txt -size 64 64 -output expected/out1.tga");
    std::fs::copy(env!("CARGO_BIN_EXE_raycaster"), student.join("raycaster")).unwrap();
    let secret = teacher.join("grades.txt");
    std::fs::write(&secret, SECRET).unwrap();
    Some(Class { _root: root, assignment, student, teacher, secret })
}

fn which(name: &str) -> bool {
    std::env::split_paths(&std::env::var_os("PATH").unwrap_or_default()).any(|d| d.join(name).is_file())
}

fn render(dir: &Path, line: &str) {
    let result = command().args(line.split_whitespace()).args(["--backend", "cpu", "-q"]).current_dir(dir).output();
    let result = result.unwrap();
    assert!(result.status.success(), "{line}: {}", stderr(&result));
}

impl Class {
    /// A shell script of the student's, `raytracer.sh`; `{bin}` in it is our binary beside it,
    /// `{secret}` the teacher's file, `{assignment}` the assignment's folder.
    fn program(&self, name: &str, script: &str) -> String {
        let script = script
            .replace("{bin}", path_str(&self.student.join("raycaster")))
            .replace("{secret}", path_str(&self.secret))
            .replace("{teacher}", path_str(&self.teacher))
            .replace("{assignment}", path_str(&self.assignment))
            .replace("{find}", FIND);
        let path = self.student.join(name);
        std::fs::write(&path, format!("#!/bin/sh\n{script}\n")).unwrap();
        std::fs::set_permissions(&path, std::fs::Permissions::from_mode(0o755)).unwrap();
        format!("sh {}", path.display())
    }

    /// `grade` of the assignment with `args` after it, cut off (and failed) past a minute.
    fn grade(&self, args: &[&str]) -> Output {
        let child = command()
            .arg("grade")
            .arg(&self.assignment)
            .args(args)
            .args(["--backend", "cpu"])
            .env("RAYCASTER_TEST_TOKEN", SECRET)
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap();
        finish_within(child, Duration::from_secs(60))
    }

    fn html(&self) -> PathBuf {
        self.teacher.join("report/grade.html")
    }
}

/// `child`'s output, failing the test if it runs past `limit` (a hung grader).
fn finish_within(child: std::process::Child, limit: Duration) -> Output {
    let id = child.id();
    let (send, receive) = std::sync::mpsc::channel();
    std::thread::spawn(move || send.send(child.wait_with_output()));
    match receive.recv_timeout(limit) {
        Ok(output) => output.unwrap(),
        Err(_) => {
            // SAFETY: kill with plain integers.
            unsafe { libc::kill(id as i32, libc::SIGKILL) };
            panic!("grade still running after {} s: it hangs", limit.as_secs());
        }
    }
}

/// The processes on the machine whose command line contains `marker`.
fn processes_with(marker: &str) -> Vec<String> {
    let mut found = Vec::new();
    for entry in std::fs::read_dir("/proc").unwrap().flatten() {
        if let Ok(cmdline) = std::fs::read(entry.path().join("cmdline")) {
            let text = String::from_utf8_lossy(&cmdline).replace('\0', " ");
            if text.contains(marker) {
                found.push(text);
            }
        }
    }
    found
}

/// Where a thief looks: every temporary folder, all of it, and the whole file system to a
/// depth that holds a temporary folder's files (a search of all of `/` on a developer's
/// machine would take minutes).
const FIND: &str = "find /tmp /var/tmp ${TMPDIR:-/tmp} / -maxdepth 5 -path /proc -prune -o";

/// A legitimate student: renders each line with our binary. Used as the end of hostile
/// scripts that also want their images judged.
const RENDER: &str = "exec {bin} \"$@\" --backend cpu -q";

#[test]
fn a_legitimate_program_passes_and_is_given_no_preview_flags() {
    let Some(class) = class() else { return };
    let run = class.program("raytracer.sh", &format!("echo \"args: $*\" >&2\n{RENDER}"));
    let html = class.html();
    let result = class.grade(&["--run", &run, "--html", path_str(&html), "-q"]);
    let report = stdout(&result);
    assert!(result.status.success(), "{report}{}", stderr(&result));
    assert!(report.ends_with("grade: 4 of 4 images pass\n"), "{report}");
    let page = std::fs::read_to_string(&html).unwrap();
    // The preview's flags are gone: the program's stderr ends with its words.
    assert!(
        page.contains("args: -input mesh_octahedron.txt -size 48 40 -output out2.tga -normals out2n.tga</div>"),
        "{page}"
    );
}

/// Our render of a line, and the course's `expected/` image, are where the program cannot
/// reach: a program that searches the whole file system for them and copies what it finds
/// writes nothing, and every line is missing. Without the sandbox the same program finds
/// our reference and passes, which is what the sandbox is for.
#[test]
fn our_references_and_the_course_images_are_out_of_reach() {
    let Some(class) = class() else { return };
    let run = class.program(
        "thief.sh",
        "for name in $(echo \"$*\" | tr ' ' '\\n' | grep '\\.tga$'); do\n\
           found=$({find} -name \"$name\" -type f 2>/dev/null | grep -v \"^$PWD/$name$\" | head -1)\n\
           [ -n \"$found\" ] && cp \"$found\" \"$name\" && echo \"STOLEN $found\" >&2\n\
           cp {assignment}/expected/\"$name\" \"$name\" 2>/dev/null && echo \"STOLEN expected\" >&2\n\
         done\necho SEARCHED >&2\nexit 0",
    );
    let html = class.html();
    let result = class.grade(&["--run", &run, "--html", path_str(&html), "-q"]);
    let report = stdout(&result);
    assert_eq!(result.status.code(), Some(1), "{report}{}", stderr(&result));
    assert_eq!(report.matches("MISSING").count(), 4, "{report}");
    let page = std::fs::read_to_string(&html).unwrap();
    assert!(page.contains("SEARCHED") && !page.contains("STOLEN"), "{page}");

    let unsandboxed = class.grade(&["--run", &run, "--no-sandbox", "-q"]);
    let report = stdout(&unsandboxed);
    assert!(report.starts_with("NOT SANDBOXED (--no-sandbox)"), "{report}");
    assert!(report.ends_with("grade: 4 of 4 images pass\n"), "without the sandbox the thief passes: {report}");
}

/// A program that writes junk (a picture of another scene) over every file named like its
/// outputs that it can reach, then writes the same junk as its outputs: the junk is judged
/// against our own render, and fails; the page's "ours" is ours. Without the sandbox the
/// junk overwrites our reference, and passes.
#[test]
fn overwriting_our_reference_changes_nothing() {
    let Some(class) = class() else { return };
    let run = class.program(
        "vandal.sh",
        "scene=$(echo \"$*\" | sed 's/.*-input \\([^ ]*\\).*/\\1/')\n\
         size=$(echo \"$*\" | sed 's/.*-size \\([0-9]*\\) \\([0-9]*\\).*/\\1 \\2/')\n\
         {bin} -input $scene -size $size -normals /tmp/junk.tga --backend cpu -q\n\
         for name in $(echo \"$*\" | tr ' ' '\\n' | grep '\\.tga$'); do\n\
           for f in $({find} -name \"$name\" -type f 2>/dev/null); do cp /tmp/junk.tga \"$f\" 2>/dev/null; done\n\
           cp /tmp/junk.tga \"$name\"\n\
         done",
    );
    let unsandboxed = class.grade(&["--run", &run, "--no-sandbox", "-q"]);
    assert!(report_line(&stdout(&unsandboxed), "out3.tga").starts_with("pass"), "{}", stdout(&unsandboxed));
    let html = class.html();
    let result = class.grade(&["--run", &run, "--html", path_str(&html), "-q"]);
    let report = stdout(&result);
    assert!(report_line(&report, "out3.tga").starts_with("FAIL"), "{report}");
    // Ours on the page is our render, pixel for pixel.
    render(&class.teacher, "-input ../a9/spheres_ortho.txt -size 32 32 -output ours3.png");
    let ours = raycaster::image_io::read_image(&class.teacher.join("ours3.png")).unwrap();
    let page = std::fs::read_to_string(&html).unwrap();
    let card = page.split("<div class=\"card").find(|c| c.contains("<h3>out3.tga</h3>")).unwrap();
    let picture = card.split("<img src=\"").nth(1).unwrap().split('"').next().unwrap();
    let shown = raycaster::image_io::read_image(&html.parent().unwrap().join(picture)).unwrap();
    assert!(shown == ours, "the page's reference is not our render");
}

/// The program's environment is PATH, HOME, LANG and what --env passes; the grader's
/// process, its folder and the teacher's files are not there to read.
#[test]
fn the_environment_the_grader_and_the_teachers_files_are_not_visible() {
    let Some(class) = class() else { return };
    let run = class.program(
        "spy.sh",
        "echo \"ENV[$(env | cut -d= -f1 | sort | tr '\\n' ' ')]\" >&2\n\
         env >&2; cat /proc/$PPID/environ /proc/1/environ >&2 2>&1; ls /proc/$PPID/cwd/ >&2 2>&1\n\
         cat {secret} >&2 2>&1; ls {teacher} /home /root /work 2>/dev/null | sed 's/^/LISTED /' >&2\n\
         echo \"PROCS[$(ls /proc | grep -c '^[0-9]')]\" >&2\necho SPIED >&2",
    );
    let html = class.html();
    let result = class.grade(&["--run", &run, "--env", "OMP_NUM_THREADS=1", "--html", path_str(&html), "-q"]);
    assert_eq!(result.status.code(), Some(1), "{}", stderr(&result));
    let page = std::fs::read_to_string(&html).unwrap();
    assert!(page.contains("SPIED"), "the spy ran");
    assert!(!page.contains(SECRET), "a secret leaked:\n{page}");
    assert!(page.contains("ENV[HOME LANG OMP_NUM_THREADS PATH PWD ]"), "{page}");
    assert!(!page.contains("LISTED"), "a folder of the teacher's was listed:\n{page}");
    // The keeper, the script's shell, the subshell of `$(…)`, `ls` and `grep`: no one else's.
    let procs: Vec<u32> =
        page.match_indices("PROCS[").map(|(k, _)| page[k + 6..].split(']').next().unwrap().parse().unwrap()).collect();
    assert!(!procs.is_empty() && procs.iter().all(|&n| n <= 5), "{procs:?}");
}

/// Children left behind, plain, `setsid` or double-forked, after a normal exit and after a
/// time-out: none outlives its line.
#[test]
fn no_process_outlives_its_line() {
    let Some(class) = class() else { return };
    let run = class.program(
        "leaver.sh",
        "sleep 97.5 & setsid sleep 97.25 & (setsid sh -c 'sleep 97.125' &)\n\
         case \"$*\" in *out3*) sleep 30;; esac\nexit 0",
    );
    let result = class.grade(&["--run", &run, "--time-limit", "1", "-q"]);
    let report = stdout(&result);
    assert!(report_line(&report, "out3.tga").contains("limit hit: wall"), "{report}");
    for marker in ["sleep 97.5", "sleep 97.25", "sleep 97.125"] {
        assert_eq!(processes_with(marker), Vec::<String>::new(), "{marker} survived");
    }
}

/// A program that stops its parent and every process it can see, offers a FIFO and a link
/// to /dev/zero as its images, and closes its stderr: the grader neither hangs nor reads
/// without bound; the images are refused by name.
#[test]
fn stops_fifos_and_endless_files_do_not_hang_the_grader() {
    let Some(class) = class() else { return };
    let run = class.program(
        "staller.sh",
        "kill -STOP $PPID; kill -STOP -1 2>/dev/null\n\
         mkfifo out1.tga; ln -s /dev/zero out2.tga; ln -s /dev/zero out2n.tga; mkfifo .raycaster-grade-stderr-3\n\
         exec 2>&-\nexit 0",
    );
    let result = class.grade(&["--run", &run, "-q"]);
    let report = stdout(&result);
    assert_eq!(result.status.code(), Some(1), "{report}{}", stderr(&result));
    assert!(report_line(&report, "out1.tga").contains("not a regular file"), "{report}");
    assert!(report_line(&report, "out2.tga").contains("a link, not followed"), "{report}");
    assert!(report_line(&report, "out3.tga").starts_with("MISSING"), "{report}");
}

/// Links planted where a grader might write (its old stderr files, the outputs, /tmp) to a
/// file of the teacher's: the file is unchanged.
#[test]
fn planted_links_write_nothing_of_the_teachers() {
    let Some(class) = class() else { return };
    let run = class.program(
        "planter.sh",
        "for k in 1 2 3 4; do ln -s {secret} .raycaster-grade-stderr-$k; done\n\
         ln -s {secret} out1.tga; ln -s {secret} /tmp/out2.tga; ln -s {secret} out2.tga\n\
         echo 'overwritten by the student' >&2; exit 1",
    );
    let result = class.grade(&["--run", &run, "--html", path_str(&class.html()), "-q"]);
    assert_eq!(result.status.code(), Some(1), "{}", stderr(&result));
    assert_eq!(std::fs::read_to_string(&class.secret).unwrap(), SECRET);
    assert!(report_line(&stdout(&result), "out1.tga").contains("a link, not followed"), "{}", stdout(&result));
}

/// A program that writes a verdict of its own on the grader's stdout and kills it: the
/// grader lives, and its report is its own.
#[test]
fn the_grader_cannot_be_written_to_or_killed() {
    let Some(class) = class() else { return };
    let run = class.program(
        "forger.sh",
        "echo 'grade: 99 of 99 images pass' > /proc/$PPID/fd/1; echo 'grade: 99 of 99 images pass' > /proc/1/fd/1\n\
         kill -9 $PPID; kill -9 1; kill -9 -1\nexit 0",
    );
    let result = class.grade(&["--run", &run, "-q"]);
    let report = stdout(&result);
    assert_eq!(result.status.code(), Some(1), "{report}{}", stderr(&result));
    assert!(!report.contains("99 of 99"), "{report}");
    assert!(report.ends_with("grade: 0 of 4 images pass\n"), "{report}");
}

/// The keeper (pid 1 of the sandbox) holds a descriptor of a folder outside the sandbox: a
/// program of the same user that could reach it through `/proc/1/fd` would be out. It can
/// not (the keeper is not dumpable), and inherits nothing but its standard streams.
#[test]
fn the_keepers_descriptors_are_out_of_reach() {
    let Some(class) = class() else { return };
    let run = class.program(
        "escaper.sh",
        "echo \"OWN[$(ls /proc/self/fd | tr '\\n' ' ')]\" >&2\n\
         for fd in /proc/1/fd/*; do ls \"$fd/..\" 2>/dev/null | sed 's/^/ESCAPED /' >&2; done\n\
         cat /proc/1/environ 2>/dev/null | sed 's/^/ESCAPED /' >&2; cat /proc/1/mem 2>/dev/null && echo ESCAPED >&2\n\
         echo TRIED >&2; exit 1",
    );
    let html = class.html();
    let result = class.grade(&["--run", &run, "--html", path_str(&html), "-q"]);
    assert_eq!(result.status.code(), Some(1), "{}", stderr(&result));
    let page = std::fs::read_to_string(&html).unwrap();
    assert!(page.contains("TRIED") && !page.contains("ESCAPED"), "{page}");
    // 0, 1, 2, and the one `ls` opens on the folder it lists.
    assert!(page.contains("OWN[0 1 2 3 ]"), "{page}");
}

/// Where no sandbox can be made (no bubblewrap; one that cannot make namespaces, as on a
/// kernel without unprivileged user namespaces), `--run` refuses with status 2 and says
/// how to enable one; `--no-sandbox` runs the program all the same, and says so first.
#[test]
fn without_a_sandbox_run_refuses_unless_told_to_trust() {
    let Some(class) = class() else { return };
    let run = class.program("raytracer.sh", RENDER);
    let cases = [
        ("/nonexistent/bwrap", "bubblewrap (bwrap) is not installed: `sudo apt-get install bubblewrap`"),
        ("/bin/false", "no sandbox can be made here"),
    ];
    for (bwrap, message) in cases {
        let with = |extra: &[&str]| {
            let mut args = vec!["grade", path_str(&class.assignment), "--run", &run, "--backend", "cpu", "-q"];
            args.extend(extra);
            command().args(&args).env("RAYCASTER_BWRAP", bwrap).output().unwrap()
        };
        let refused = with(&[]);
        assert_eq!(refused.status.code(), Some(2), "{}", stderr(&refused));
        assert!(
            stderr(&refused).contains(message) && stderr(&refused).contains("--no-sandbox"),
            "{}",
            stderr(&refused)
        );
        assert!(stdout(&refused).is_empty(), "nothing was graded");
        let trusted = with(&["--no-sandbox"]);
        let report = stdout(&trusted);
        assert!(report.starts_with("NOT SANDBOXED") && report.ends_with("grade: 4 of 4 images pass\n"), "{report}");
    }
}

/// Interrupted (SIGINT, SIGTERM) while a student's line runs, grade kills it and leaves no
/// folder of its own; killed (SIGKILL), it leaves one, which the next grade removes.
#[test]
fn interrupted_or_killed_grade_leaves_no_folders() {
    let Some(class) = class() else { return };
    let run = class.program("sleeper.sh", "sleep 41.0625\nexit 1");
    let temp = class.teacher.join("tmp");
    std::fs::create_dir(&temp).unwrap();
    std::fs::set_permissions(&temp, std::fs::Permissions::from_mode(0o777)).unwrap();
    let ours = |dir: &Path| -> Vec<String> {
        let names = std::fs::read_dir(dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned());
        names.filter(|n| n.starts_with("raycaster-grade-")).collect()
    };
    for signal in [libc::SIGINT, libc::SIGTERM, libc::SIGKILL] {
        let mut child = command()
            .arg("grade")
            .arg(&class.assignment)
            .args(["--run", &run, "--backend", "cpu", "-q"])
            .env("TMPDIR", &temp)
            .stdout(std::process::Stdio::null())
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap();
        let start = Instant::now();
        while processes_with("sleep 41.0625").is_empty() {
            assert!(start.elapsed() < Duration::from_secs(30), "the student's line never started");
            std::thread::sleep(Duration::from_millis(20));
        }
        assert_eq!(ours(&temp).len(), 1, "grade's folder while it runs");
        // SAFETY: kill with plain integers, to our own child.
        unsafe { libc::kill(child.id() as i32, signal) };
        let status = child.wait().unwrap();
        std::thread::sleep(Duration::from_millis(200));
        assert!(processes_with("sleep 41.0625").is_empty(), "signal {signal}: the student's line survived");
        if signal == libc::SIGKILL {
            let left = ours(&temp);
            assert_eq!(left.len(), 1, "SIGKILL leaves the folder");
            // Older than a folder being made, which the sweep leaves alone (src/app/scratch.rs).
            let lock = std::fs::File::options().write(true).open(temp.join(&left[0]).join(".lock")).unwrap();
            lock.set_modified(std::time::SystemTime::now() - Duration::from_secs(60)).unwrap();
            let next = command()
                .arg("grade")
                .arg(&class.assignment)
                .args(["--images", path_str(&class.student), "--backend", "cpu", "-q"])
                .env("TMPDIR", &temp)
                .output()
                .unwrap();
            assert_eq!(next.status.code(), Some(1), "{}", stderr(&next));
        } else {
            assert_eq!(status.code(), Some(128 + signal), "signal {signal}");
        }
        assert_eq!(ours(&temp), Vec::<String>::new(), "signal {signal}: a folder was left");
    }
}

/// 200 MB of invalid UTF-8 on stderr: the grader keeps its end only; its peak memory stays
/// far below the flood's size.
#[test]
fn a_flood_on_stderr_costs_the_grader_a_few_kilobytes() {
    let Some(class) = class() else { return };
    let run = class.program(
        "flooder.sh",
        &format!("head -c 200000000 /dev/zero | tr '\\0' '\\377' >&2\necho 'the last words' >&2\n{RENDER}"),
    );
    let (result, peak) = grade_with_peak_memory(&class, &["--run", &run, "--html", path_str(&class.html()), "-q"]);
    let report = stdout(&result);
    assert!(report.ends_with("grade: 4 of 4 images pass\n"), "{report}{}", stderr(&result));
    let page = std::fs::read_to_string(class.html()).unwrap();
    assert!(page.contains("the last lines of 200000015 bytes") && page.contains("the last words"));
    assert!(page.len() < 200_000, "the page holds {} bytes", page.len());
    println!("grade's peak memory with 200 MB on stderr: {} MiB", peak >> 20);
    assert!(peak < 100 << 20, "peak memory {} MiB", peak >> 20);
}

/// `grade` of the class with `args`, and its peak resident memory (`wait4`'s `ru_maxrss`
/// of that one process, reaped here).
fn grade_with_peak_memory(class: &Class, args: &[&str]) -> (Output, u64) {
    use std::io::Read;
    use std::os::unix::process::ExitStatusExt;
    let mut child = command()
        .arg("grade")
        .arg(&class.assignment)
        .args(args)
        .args(["--backend", "cpu"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let (mut out, mut err) = (child.stdout.take().unwrap(), child.stderr.take().unwrap());
    let out = std::thread::spawn(move || {
        let mut bytes = Vec::new();
        out.read_to_end(&mut bytes).map(|_| bytes)
    });
    let err = std::thread::spawn(move || {
        let mut bytes = Vec::new();
        err.read_to_end(&mut bytes).map(|_| bytes)
    });
    let (mut status, mut usage) = (0, unsafe { std::mem::zeroed::<libc::rusage>() });
    // SAFETY: pointers to locals; the child is ours and not yet reaped.
    let pid = unsafe { libc::wait4(child.id() as i32, &mut status, 0, &mut usage) };
    assert_eq!(pid, child.id() as i32);
    let output = Output {
        status: std::process::ExitStatus::from_raw(status),
        stdout: out.join().unwrap().unwrap(),
        stderr: err.join().unwrap().unwrap(),
    };
    (output, usage.ru_maxrss as u64 * 1024)
}

/// A 300 MB file, a folder filled up, files written outside its folder: the limits stop the
/// writes, the report names them, nothing is left outside; the line's image still counts.
#[test]
fn big_files_a_full_folder_and_writes_outside_are_stopped() {
    let Some(class) = class() else { return };
    let run = class.program(
        "filler.sh",
        &format!(
            "case \"$*\" in\n\
               *out1*) head -c 300000000 /dev/zero > big;;\n\
               *out3*) for k in 1 2 3 4; do head -c 3000000 /dev/zero > fill$k; done;;\n\
             esac\n\
             echo escaped > {{teacher}}/escaped; echo escaped > {{student}}/escaped; echo escaped > /tmp/escaped-grade-test\n\
             {RENDER}"
        )
        .replace("{student}", path_str(&class.student)),
    );
    let result = class.grade(&["--run", &run, "--limit", "file=4M", "--limit", "folder=8M", "-q"]);
    let report = stdout(&result);
    assert!(report_line(&report, "out1.tga").contains("limit hit: file"), "{report}");
    assert!(report_line(&report, "out1.tga").starts_with("pass"), "{report}");
    assert!(report_line(&report, "out3.tga").contains("limit hit: folder"), "{report}");
    assert!(!report_line(&report, "out2.tga").contains("limit hit"), "{report}");
    assert!(!class.teacher.join("escaped").exists() && !class.student.join("escaped").exists());
    assert!(!Path::new("/tmp/escaped-grade-test").exists());
}

/// No network: a connection to a port the test listens on, on this machine, never arrives.
#[test]
fn the_program_has_no_network() {
    let Some(class) = class() else { return };
    let listener = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    listener.set_nonblocking(true).unwrap();
    let port = listener.local_addr().unwrap().port();
    let run = class.program(
        "caller.sh",
        &format!(
            "python3 -c 'import socket; socket.create_connection((\"127.0.0.1\", {port}), timeout=2)' 2>&1 | tail -1 >&2\n\
             echo CALLED >&2; exit 1"
        ),
    );
    let result = class.grade(&["--run", &run, "--html", path_str(&class.html()), "-q"]);
    assert_eq!(result.status.code(), Some(1), "{}", stderr(&result));
    assert!(std::fs::read_to_string(class.html()).unwrap().contains("CALLED"));
    assert!(listener.accept().is_err(), "a connection came from the sandbox");
}

/// A fork bomb is held to the process limit, ended at the line's end, and named; memory
/// past the limit is refused to the program.
#[test]
fn a_fork_bomb_and_a_memory_hog_are_held() {
    let Some(class) = class() else { return };
    let run = class.program(
        "bomb.sh",
        "bomb() {\n bomb &\n bomb &\n sleep 5\n}\n\
         case \"$*\" in\n\
           *out1*) bomb & wait;;\n\
           *out3*) python3 -c 'x = bytearray(512 << 20)' 2>&1 | tail -1 >&2;;\n\
         esac\nexit 1",
    );
    let html = class.html();
    let start = Instant::now();
    let result = class.grade(&[
        "--run",
        &run,
        "--limit",
        "processes=32",
        "--limit",
        "memory=256M",
        "--time-limit",
        "2",
        "--html",
        path_str(&html),
        "-q",
    ]);
    let report = stdout(&result);
    assert!(report_line(&report, "out1.tga").contains("processes"), "{report}");
    assert!(start.elapsed() < Duration::from_secs(50), "the bomb was not ended at its line's end");
    assert!(processes_with("bomb.sh").is_empty(), "the bomb survived");
    assert!(std::fs::read_to_string(&html).unwrap().contains("MemoryError"), "512 MB were allocated past 256M");
}

/// A commands.txt whose outputs are absolute or leave the folder: an error naming the line,
/// status 2, and the file it names is neither written nor deleted, with --images or --run.
#[test]
fn outputs_outside_the_assignment_are_refused() {
    let Some(class) = class() else { return };
    let victim = class.teacher.join("victim.tga");
    for (output, line) in [(path_str(&victim).to_string(), 2), ("../teacher/victim.tga".to_string(), 2)] {
        std::fs::write(&victim, "the teacher's").unwrap();
        std::fs::write(
            class.assignment.join("commands.txt"),
            format!("-input spheres_ortho.txt -size 8 8 -output ok.tga\n-input spheres_ortho.txt -size 8 8 -output {output}\n"),
        )
        .unwrap();
        let run = class.program("raytracer.sh", RENDER);
        for judged in [["--images", path_str(&class.student)], ["--run", &run]] {
            let result = class.grade(&[judged[0], judged[1], "-q"]);
            assert_eq!(result.status.code(), Some(2), "{}", stderr(&result));
            let expected = format!("commands.txt:{line}: {output} ");
            assert!(stderr(&result).contains(&expected), "{}", stderr(&result));
            assert_eq!(std::fs::read_to_string(&victim).unwrap(), "the teacher's");
        }
    }
}

/// `--images`: nine 0.5 MB PNGs that claim 13000×13000 are refused by their headers, never
/// decoded: the grader's memory stays small and the page copies none of them.
#[test]
fn png_bombs_are_refused_by_their_headers() {
    let Some(class) = class() else { return };
    let lines: String =
        (1..=9).map(|k| format!("-input spheres_ortho.txt -size 40 40 -output bomb{k}.png\n")).collect();
    std::fs::write(class.assignment.join("commands.txt"), lines).unwrap();
    png_bomb(&class.student.join("bomb1.png"), 13000, 13000);
    let size = std::fs::metadata(class.student.join("bomb1.png")).unwrap().len();
    assert!(size < 600_000, "{size} bytes");
    for k in 2..=9 {
        std::fs::copy(class.student.join("bomb1.png"), class.student.join(format!("bomb{k}.png"))).unwrap();
    }
    let html = class.html();
    let (result, peak) =
        grade_with_peak_memory(&class, &["--images", path_str(&class.student), "--html", path_str(&html), "-q"]);
    let report = stdout(&result);
    assert_eq!(report.matches("is 13000×13000, ours 40×40").count(), 9, "{report}");
    println!("grade's peak memory on nine PNG bombs: {} MiB", peak >> 20);
    assert!(peak < 100 << 20, "peak memory {} MiB", peak >> 20);
    let files: u64 = std::fs::read_dir(html.parent().unwrap().join("grade_files"))
        .unwrap()
        .map(|e| e.unwrap().metadata().unwrap().len())
        .sum();
    assert!(files < 100_000, "the page's pictures take {files} bytes");
}

/// A PNG of `width × height` black pixels at `path`, its rows deflated as they are made:
/// small on disk, `3·width·height` bytes once decoded.
fn png_bomb(path: &Path, width: u32, height: u32) {
    let file = std::io::BufWriter::new(std::fs::File::create(path).unwrap());
    let mut encoder = png::Encoder::new(file, width, height);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_compression(png::Compression::High);
    let writer = encoder.write_header().unwrap();
    let mut stream = writer.into_stream_writer().unwrap();
    let row = vec![0u8; width as usize * 3];
    for _ in 0..height {
        std::io::Write::write_all(&mut stream, &row).unwrap();
    }
    stream.finish().unwrap();
}

/// A compiled C++ program (libstdc++ from the system), a Python script using numpy and
/// Pillow from the system, and our own binary named as the program: all pass.
#[test]
fn compiled_python_and_our_own_programs_pass() {
    let Some(class) = class() else { return };
    let source = class.student.join("raytracer.cpp");
    std::fs::write(
        &source,
        "#include <iostream>\n#include <string>\n#include <vector>\n#include <unistd.h>\n\
         int main(int argc, char** argv) {\n\
           std::string self(argv[0]); std::string bin = self.substr(0, self.rfind('/')) + \"/raycaster\";\n\
           std::vector<char*> args{const_cast<char*>(bin.c_str())};\n\
           for (int k = 1; k < argc; ++k) args.push_back(argv[k]);\n\
           for (const char* w : {\"--backend\", \"cpu\", \"-q\"}) args.push_back(const_cast<char*>(w));\n\
           args.push_back(nullptr);\n\
           std::cerr << \"C++ raytracer, \" << argc - 1 << \" arguments\" << std::endl;\n\
           execv(bin.c_str(), args.data()); return 127; }\n",
    )
    .unwrap();
    let compiled =
        std::process::Command::new("c++").arg(&source).arg("-o").arg(class.student.join("raytracer")).output();
    let compiled = compiled.expect("a C++ compiler (CI installs g++)");
    assert!(compiled.status.success(), "{}", stderr(&compiled));
    let script = class.student.join("raytracer.py");
    std::fs::write(
        &script,
        "import os, subprocess, sys\nimport numpy as np\nfrom PIL import Image\n\
         here = os.path.dirname(os.path.abspath(__file__))\nargs = sys.argv[1:]\n\
         outputs = [args[k + 1] for k, a in enumerate(args) if a in ('-output', '-normals')]\n\
         subprocess.run([os.path.join(here, 'raycaster'), *args, '--backend', 'cpu', '-q'], check=True)\n\
         for name in outputs:\n    pixels = np.asarray(Image.open(name).convert('RGB'))\n\
             Image.fromarray(np.flipud(np.flipud(pixels))).save(name)\n",
    )
    .unwrap();
    let programs = [
        format!("{}", class.student.join("raytracer").display()),
        format!("python3 {}", script.display()),
        format!("{} --backend cpu", class.student.join("raycaster").display()),
    ];
    for program in &programs {
        let result = class.grade(&["--run", program, "-q"]);
        let report = stdout(&result);
        assert!(result.status.success(), "{program}: {report}{}", stderr(&result));
        assert!(report.ends_with("grade: 4 of 4 images pass\n"), "{program}: {report}");
    }
}

/// The sandbox for a plain user: grade itself run as `nobody` (where the tests run as
/// root, as CI's do), a legitimate program passes and the thief of the test above finds
/// nothing.
#[test]
fn the_sandbox_works_for_a_plain_user() {
    let Some(class) = class() else { return };
    // SAFETY: geteuid has no preconditions.
    if unsafe { libc::geteuid() } != 0 {
        // Already a plain user: every other test of this file is this one.
        return;
    }
    let report_dir = class.teacher.join("out");
    std::fs::create_dir(&report_dir).unwrap();
    std::fs::set_permissions(&report_dir, std::fs::Permissions::from_mode(0o777)).unwrap();
    let legit = class.program("raytracer.sh", RENDER);
    let thief = class
        .program("thief.sh", "for f in $({find} -name 'out*.tga' -type f 2>/dev/null); do cp \"$f\" . ; done; exit 0");
    for (run, passing) in [(&legit, 4), (&thief, 0)] {
        let child = std::process::Command::new("setpriv")
            .args(["--reuid=65534", "--regid=65534", "--clear-groups", "--"])
            .arg(env!("CARGO_BIN_EXE_raycaster"))
            .arg("grade")
            .arg(&class.assignment)
            .args(["--run", run, "--backend", "cpu", "-q"])
            .env("HOME", "/nonexistent")
            .env("TMPDIR", &report_dir)
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .expect("setpriv (util-linux)");
        let result = finish_within(child, Duration::from_secs(60));
        let report = stdout(&result);
        assert!(
            report.ends_with(&format!("grade: {passing} of 4 images pass\n")),
            "{run}: {report}{}",
            stderr(&result)
        );
    }
}
