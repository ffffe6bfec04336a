//! The sandbox a student's program runs in, one per command line: bubblewrap (`bwrap`, the
//! sandbox under Flatpak, a package of every major distribution) builds it from Linux
//! namespaces, and our [`keeper`](super::keeper) runs inside as its first process.
//!
//! What the program sees (docs/grading.md, "The sandbox"): the system's folders read-only
//! (`/usr`, `/etc`, the `/lib*` and `/bin` links, `/opt`), its own files read-only where
//! the command line names them, a fresh working folder `/assignment` (a tmpfs of the
//! `folder` limit) holding the line's scene and meshes read-only, a private `/tmp` of the same
//! size, a `/proc` of its own processes and a minimal `/dev`; no network, no other process,
//! no host name, no IPC, no nested user namespace, an environment of `PATH`, `HOME`, `LANG`
//! and what the teacher passes. Run as root, grade starts bwrap as `nobody` (65534), so
//! that the program is never root, inside or out.

use crate::app::args::{Limits, RunArgs};
use crate::app::grade::keeper;
use crate::app::grade::student::Hidden;
use crate::app::grade::untrusted;
use std::ffi::OsString;
use std::os::fd::AsRawFd;
use std::os::unix::fs::{MetadataExt, PermissionsExt};
use std::os::unix::process::CommandExt;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// Where the line runs inside the sandbox.
pub const WORKING_FOLDER: &str = "/assignment";
/// Where the keeper's executable is bound inside.
const KEEPER: &str = "/run/raycaster-keeper";
/// The user a root grader runs the sandbox as.
const NOBODY: u32 = 65534;
/// The system's folders, bound read-only where they are folders and copied as links where
/// they are links (`/bin` → `usr/bin` on a merged-/usr system).
const SYSTEM: [&str; 9] = ["/usr", "/bin", "/sbin", "/lib", "/lib32", "/lib64", "/libx32", "/etc", "/opt"];
/// What the keeper may take beyond the wall time to start and to copy the outputs out,
/// before grade kills the whole sandbox.
const GRACE: Duration = Duration::from_secs(5);

/// A sandbox ready to run lines of one program.
pub struct Sandbox {
    bwrap: PathBuf,
    /// The keeper's executable on the host.
    keeper: PathBuf,
    /// The user and group to run bwrap as, when grade runs as root.
    run_as: Option<u32>,
    /// The program's own folders, bound read-only at their own paths.
    program_folders: Vec<PathBuf>,
    /// Folders inside those that the program must not see: masked with an empty tmpfs.
    hidden: Vec<PathBuf>,
    env: Vec<String>,
    limits: Limits,
}

/// What a line's sandbox gives back: the keeper's `status`, or why there is none, and the
/// outbox holding the outputs.
pub struct Finished {
    pub status: Result<String, String>,
}

impl Sandbox {
    /// A sandbox for `run`'s program, `words` being its command line with paths made
    /// absolute; `hidden` are folders of the teacher's that it must not see, even inside its
    /// own folders; `scratch` is grade's private folder (the keeper may be copied there).
    /// `Err` says why no sandbox can be made here, and how to make one possible.
    pub fn new(run: &RunArgs, words: &[String], hidden: &Hidden, scratch: &Path) -> Result<Sandbox, String> {
        let bwrap = bwrap().ok_or(
            "bubblewrap (bwrap) is not installed: `sudo apt-get install bubblewrap` (Debian, Ubuntu) or \
             `sudo dnf install bubblewrap` (Fedora)",
        )?;
        // SAFETY: geteuid has no preconditions.
        let run_as = (unsafe { libc::geteuid() } == 0).then_some(NOBODY);
        let mut keeper = keeper_executable()?;
        if run_as.is_some() && !readable_by_others(&keeper) {
            keeper = copy_for_others(&keeper, scratch)?;
        }
        let program_folders = program_folders(words, &hidden.forbidden)?;
        if run_as.is_some() {
            if let Some(folder) = program_folders.iter().find(|f| !readable_by_others(f)) {
                return Err(format!(
                    "{}: the program's folder must be readable by the sandbox's user nobody when grade runs \
                     as root (chmod -R o+rX it), or run grade as a plain user",
                    folder.display()
                ));
            }
        }
        let inside_a_program_folder = |h: &&PathBuf| program_folders.iter().any(|f| h.starts_with(f) && *h != f);
        let hidden = hidden.forbidden.iter().chain(&hidden.masked).filter(inside_a_program_folder).cloned().collect();
        let sandbox =
            Sandbox { bwrap, keeper, run_as, program_folders, hidden, env: run.env.clone(), limits: run.limits };
        sandbox.try_once(scratch)?;
        Ok(sandbox)
    }

    /// Runs `true` in a sandbox of this kind: where that fails, nothing would run.
    fn try_once(&self, scratch: &Path) -> Result<(), String> {
        let outbox = scratch.join("probe");
        let words = ["true".to_string()];
        let (finished, stderr) = self.run(&[], &[], &words, &outbox, &mut |_| {})?;
        let _ = std::fs::remove_dir_all(&outbox);
        match finished.status {
            Ok(status) if status.starts_with("ended exited 0") => Ok(()),
            Ok(status) => Err(format!("a sandbox runs nothing here: `true` {}", status.lines().next().unwrap_or(""))),
            Err(why) => Err(format!(
                "no sandbox can be made here: {why}{}. Where unprivileged user namespaces are off, enable them \
                 (`sudo sysctl kernel.unprivileged_userns_clone=1`; on Ubuntu 24.04 and later \
                 `sudo sysctl kernel.apparmor_restrict_unprivileged_userns=0`, or an AppArmor profile for bwrap)",
                stderr.trim().lines().last().map_or(String::new(), |l| format!(" ({l})")),
            )),
        }
    }

    /// Runs `words` in a fresh sandbox holding `inputs` (paths relative to `assignment`,
    /// bound read-only at the same place under the working folder), waits for it and for
    /// the keeper's copy of `outputs` into `outbox` (created here). `started` hears the
    /// process group, to kill it on an interrupt. The second value is the end of stderr.
    pub fn run(
        &self,
        inputs: &[(PathBuf, PathBuf)],
        outputs: &[PathBuf],
        words: &[String],
        outbox: &Path,
        started: &mut dyn FnMut(Option<u32>),
    ) -> Result<(Finished, String), String> {
        std::fs::create_dir(outbox).map_err(|e| format!("{}: {e}", outbox.display()))?;
        if let Some(user) = self.run_as {
            std::os::unix::fs::chown(outbox, Some(user), Some(user))
                .map_err(|e| format!("{}: {e}", outbox.display()))?;
        }
        let outbox_fd = std::fs::File::open(outbox).map_err(|e| format!("{}: {e}", outbox.display()))?;
        // The inputs reach bwrap open, not by name: a user it runs as need not be able to read
        // the teacher's folders, and bwrap copies each into the sandbox.
        let opened: Vec<(std::fs::File, PathBuf)> = inputs
            .iter()
            .map(|(host, place)| std::fs::File::open(host).map(|f| (f, place.clone())))
            .collect::<Result<_, _>>()
            .map_err(|e| format!("the line's scene or meshes: {e}"))?;
        let (stderr, tail) = super::stderr::capture().map_err(|e| format!("a pipe for stderr: {e}"))?;
        let mut command = Command::new(&self.bwrap);
        let passed: Vec<(i32, &Path)> = opened.iter().map(|(f, place)| (f.as_raw_fd(), place.as_path())).collect();
        command.args(self.arguments(&passed, outbox_fd.as_raw_fd(), outputs, words));
        command.env_clear().stdin(Stdio::null()).stdout(Stdio::null()).stderr(stderr);
        command.process_group(0);
        if let Some(user) = self.run_as {
            command.uid(user).gid(user);
        }
        let inherited: Vec<i32> = passed.iter().map(|(fd, _)| *fd).chain([outbox_fd.as_raw_fd()]).collect();
        // SAFETY: fcntl only, between fork and exec: these descriptors stay open in bwrap.
        unsafe {
            command.pre_exec(move || {
                for &fd in &inherited {
                    if libc::fcntl(fd, libc::F_SETFD, 0) != 0 {
                        return Err(std::io::Error::last_os_error());
                    }
                }
                Ok(())
            });
        }
        let child = command.spawn().map_err(|e| format!("{}: {e}", self.bwrap.display()))?;
        drop(command);
        drop((outbox_fd, opened));
        started(Some(child.id()));
        let ended = wait_or_kill(child, Duration::from_secs_f64(self.limits.wall) + GRACE);
        started(None);
        let stderr = tail.finish();
        let status = match ended {
            Ok(()) => read_status(outbox),
            Err(why) => Err(why),
        };
        Ok((Finished { status }, stderr))
    }

    fn arguments(&self, inputs: &[(i32, &Path)], outbox: i32, outputs: &[PathBuf], words: &[String]) -> Vec<OsString> {
        let mut a = Arguments::default();
        for folder in SYSTEM {
            match std::fs::read_link(folder) {
                Ok(target) => a.add(["--symlink"]).path(&target).add([folder]),
                Err(_) if Path::new(folder).is_dir() => a.add(["--ro-bind", folder, folder]),
                Err(_) => &mut a,
            };
        }
        a.add(["--proc", "/proc", "--dev", "/dev"]);
        a.add(["--perms", "1777", "--size"]).add([self.limits.folder.to_string()]).add(["--tmpfs", "/tmp"]);
        a.add(["--ro-bind"]).path(&self.keeper).add([KEEPER]);
        for folder in &self.program_folders {
            a.add(["--ro-bind"]).path(folder).path(folder);
        }
        for hidden in &self.hidden {
            a.add(["--tmpfs"]).path(hidden);
        }
        a.add(["--perms", "0755", "--size"]).add([self.limits.folder.to_string()]).add(["--tmpfs", WORKING_FOLDER]);
        // A scene named `../scene.txt` is placed where it would be: `/scene.txt`.
        let from_root = |relative: &Path| {
            untrusted::lexically_beneath(Path::new("/"), &Path::new(&WORKING_FOLDER[1..]).join(relative))
        };
        for (fd, place) in inputs.iter().filter_map(|(fd, relative)| Some((fd, from_root(relative)?))) {
            a.add(["--perms", "0444", "--ro-bind-data"]).add([fd.to_string()]).path(&place);
        }
        a.add(["--chdir", WORKING_FOLDER, "--clearenv"]);
        a.add(["--setenv", "PATH", "/usr/local/bin:/usr/bin:/bin", "--setenv", "HOME", "/tmp"]);
        a.add(["--setenv", "LANG", "C.UTF-8"]);
        for var in &self.env {
            let (name, value) = var.split_once('=').unwrap_or((var, ""));
            a.add(["--setenv", name, value]);
        }
        a.add(["--unshare-user", "--unshare-ipc", "--unshare-pid", "--unshare-net", "--unshare-uts"]);
        a.add(["--unshare-cgroup-try", "--disable-userns", "--die-with-parent", "--new-session", "--as-pid-1"]);
        a.add(["--", KEEPER, keeper::ARG]).add([keeper::limits_word(&self.limits), outbox.to_string()]);
        for output in outputs {
            a.path(output);
        }
        a.add(["--"]).add(words.iter().cloned());
        a.0
    }
}

/// bwrap's command line, built in order.
#[derive(Default)]
struct Arguments(Vec<OsString>);

impl Arguments {
    fn add<S: Into<OsString>>(&mut self, words: impl IntoIterator<Item = S>) -> &mut Arguments {
        self.0.extend(words.into_iter().map(Into::into));
        self
    }

    fn path(&mut self, path: &Path) -> &mut Arguments {
        self.0.push(path.as_os_str().to_owned());
        self
    }
}

/// Waits for bwrap until `limit`, then kills its process group (bwrap's
/// `--die-with-parent` takes the sandbox's processes with it).
fn wait_or_kill(mut child: Child, limit: Duration) -> Result<(), String> {
    let start = Instant::now();
    loop {
        match child.try_wait() {
            Ok(Some(_)) => return Ok(()),
            Ok(None) if start.elapsed() < limit => std::thread::sleep(Duration::from_millis(1)),
            Ok(None) => {
                super::student::kill_group(&mut child);
                return Err(format!("the sandbox did not end within {} s; killed", limit.as_secs_f64()));
            }
            Err(e) => {
                super::student::kill_group(&mut child);
                return Err(format!("the sandbox could not be waited for: {e}"));
            }
        }
    }
}

/// The keeper's status file, read as any file the student could have touched (it cannot).
fn read_status(outbox: &Path) -> Result<String, String> {
    let file = untrusted::open_beneath(outbox, Path::new(keeper::STATUS))
        .map_err(|_| "the sandbox ended before its keeper wrote a status".to_string())?;
    let bytes = untrusted::read_at_most(file, 64 * 1024)?;
    Ok(String::from_utf8_lossy(&bytes).into_owned())
}

/// The folders of the program's own files: for each word of its command line that is an
/// absolute path, the folder holding it (or the folder itself), outside the system's.
fn program_folders(words: &[String], hidden: &[PathBuf]) -> Result<Vec<PathBuf>, String> {
    let home = std::env::var_os("HOME").map(PathBuf::from);
    let mut folders: Vec<PathBuf> = Vec::new();
    for word in words.iter().map(Path::new).filter(|w| w.is_absolute() && w.exists()) {
        let folder = if word.is_dir() { word.to_path_buf() } else { word.parent().unwrap_or(word).to_path_buf() };
        if SYSTEM.iter().any(|s| folder.starts_with(s)) || folders.contains(&folder) {
            continue;
        }
        let too_wide = folder.parent().is_none() || home.as_ref().is_some_and(|h| h.starts_with(&folder));
        if too_wide {
            return Err(format!(
                "{}: the program's folder would put all of it in the sandbox; give the program a folder of its own",
                folder.display()
            ));
        }
        if let Some(inside) = hidden.iter().find(|h| folder.starts_with(h)) {
            return Err(format!(
                "{}: the program is inside {}, which it must not see; move it out",
                folder.display(),
                inside.display()
            ));
        }
        if folder.starts_with(WORKING_FOLDER) {
            return Err(format!("{}: the sandbox's working folder is {WORKING_FOLDER}; move it", folder.display()));
        }
        folders.push(folder);
    }
    Ok(folders)
}

/// Whether a user of neither `path`'s owner nor group may read it, and enter each folder
/// on the way to it.
fn readable_by_others(path: &Path) -> bool {
    let Ok(path) = path.canonicalize() else { return false };
    // A folder must be listed and entered; a file read (and an executable run).
    let own = std::fs::metadata(&path).is_ok_and(|m| {
        let needed = if m.is_dir() || m.mode() & 0o100 != 0 { 0o005 } else { 0o004 };
        m.mode() & needed == needed
    });
    own && path.ancestors().skip(1).all(|a| std::fs::metadata(a).is_ok_and(|m| m.permissions().mode() & 0o001 != 0))
}

/// A copy of `exe` that any user can run, in `scratch` (made enterable by them).
fn copy_for_others(exe: &Path, scratch: &Path) -> Result<PathBuf, String> {
    let named = |e: std::io::Error| format!("copying {} for the sandbox: {e}", exe.display());
    std::fs::set_permissions(scratch, std::fs::Permissions::from_mode(0o711)).map_err(named)?;
    let bin = scratch.join("bin");
    std::fs::create_dir_all(&bin).map_err(named)?;
    std::fs::set_permissions(&bin, std::fs::Permissions::from_mode(0o711)).map_err(named)?;
    let copy = bin.join("raycaster");
    std::fs::copy(exe, &copy).map_err(named)?;
    std::fs::set_permissions(&copy, std::fs::Permissions::from_mode(0o755)).map_err(named)?;
    Ok(copy)
}

/// bubblewrap's executable: `$RAYCASTER_BWRAP` where set (a build of one's own; the tests'
/// stand-ins for a machine without it), else `bwrap` in the `PATH`.
fn bwrap() -> Option<PathBuf> {
    match std::env::var_os("RAYCASTER_BWRAP").filter(|p| !p.is_empty()) {
        Some(path) => Some(PathBuf::from(path)).filter(|p| p.is_file()),
        None => find_in_path("bwrap"),
    }
}

/// The `raycaster` binary, which runs the keeper: this process's own, or (where grade runs
/// inside another program, Python's `raycaster.run`) the one in the `PATH`.
fn keeper_executable() -> Result<PathBuf, String> {
    let own = std::env::current_exe().map_err(|e| format!("our own executable: {e}"))?;
    if own.file_stem().is_some_and(|name| name.to_string_lossy().starts_with("raycaster")) {
        return Ok(own);
    }
    find_in_path("raycaster").ok_or_else(|| {
        "the sandbox's keeper is the raycaster binary, and there is none in the PATH: install it \
         (cargo install --path .) or run grade from it"
            .to_string()
    })
}

/// `name`'s executable in the `PATH`, or in `/usr/bin`.
pub fn find_in_path(name: &str) -> Option<PathBuf> {
    let path = std::env::var_os("PATH").unwrap_or_default();
    std::env::split_paths(&path).chain([PathBuf::from("/usr/bin")]).map(|dir| dir.join(name)).find(|candidate| {
        std::fs::metadata(candidate).is_ok_and(|m| m.is_file() && m.permissions().mode() & 0o111 != 0)
    })
}
