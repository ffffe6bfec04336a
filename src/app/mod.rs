//! The `raycaster` command's own layer over the library, which renders through
//! [`raycaster::renderer::Renderer`]. Nothing here is part of the library's API. Modules import only from the layers below their own:
//!
//! 0. [`command`]: one command line dispatched to the layers below (the binary's `main`, and
//!    the Python package's `raycaster.run`), and the process's settings for Mesa's drivers;
//! 1. [`exit`]: how the command ends; [`signals`]: interrupts, ending through [`exit`];
//! 2. [`window`]: `-gui`'s live view, over [`job`];
//!    [`job`]: one command line's render, `compare`'s, and batches; [`stitch`]: assembling
//!    the parts of a split render; [`bench`]: `raycaster bench`; [`grade`]: judging a
//!    student's images, and the HTML pages; [`gallery`]: every assignment on a page;
//! 3. [`cli`]: parsing; [`validate`]: the checks of a parsed command line that look at the
//!    file system; [`output_file`]: the image files asked for and the sinks they are
//!    streamed into;
//! 4. [`flags`]: the table of flags, from which parsing, help and suggestions come;
//! 5. leaves: [`args`] (the parsed command line), [`part`] (the part-file format),
//!    [`progress`] (the progress bar), [`scratch`] (private folders that do not outlive the
//!    command), [`memory`] (the peak-memory probe), [`orbit`] (the
//!    camera the live view's mouse moves, and `bench`'s moving frames), [`interrupt`]
//!    (what can interrupt the command, and its exit status), [`lookahead`] (which lines of
//!    a batch compile their kernels ahead).

pub mod args;
pub mod bench;
pub mod cli;
pub mod command;
pub mod exit;
pub mod flags;
pub mod gallery;
pub mod grade;
pub mod interrupt;
pub mod job;
pub mod lookahead;
pub mod memory;
pub mod orbit;
pub mod output_file;
pub mod part;
pub mod progress;
pub mod scratch;
pub mod selftest;
pub mod signals;
pub mod stitch;
pub mod validate;
#[cfg(feature = "gui")]
pub mod window;
