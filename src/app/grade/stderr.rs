//! A student's stderr, through a pipe: a thread reads it as it comes and keeps only its
//! last bytes, so that a program printing gigabytes costs the grader a few kilobytes, and
//! nothing the program makes (a FIFO, a link, a file it swaps in) is ever opened by us.

use std::io::Read;
use std::process::Stdio;
use std::sync::mpsc;
use std::time::Duration;

/// The bytes kept: the end of what was printed, where a crash says why.
const KEEP_BYTES: usize = 16 * 1024;
/// The characters the report shows of them.
const SHOWN_CHARS: usize = 1500;

/// The pipe's reading end, being read.
pub struct Tail {
    done: mpsc::Receiver<(Vec<u8>, u64)>,
}

/// A pipe for a child's stderr, and its reader.
pub fn capture() -> std::io::Result<(Stdio, Tail)> {
    let (mut reader, writer) = std::io::pipe()?;
    let (send, done) = mpsc::channel();
    std::thread::Builder::new().name("stderr".into()).spawn(move || {
        let mut kept: Vec<u8> = Vec::with_capacity(KEEP_BYTES * 2);
        let mut total = 0u64;
        let mut buffer = vec![0u8; 64 * 1024];
        while let Ok(n) = reader.read(&mut buffer) {
            if n == 0 {
                break;
            }
            total += n as u64;
            kept.extend_from_slice(&buffer[..n]);
            if kept.len() > KEEP_BYTES * 2 {
                kept.drain(..kept.len() - KEEP_BYTES);
            }
        }
        let start = kept.len().saturating_sub(KEEP_BYTES);
        let _ = send.send((kept[start..].to_vec(), total));
    })?;
    Ok((Stdio::from(writer), Tail { done }))
}

impl Tail {
    /// The last lines printed, once every writer has gone (the sandbox's processes are all
    /// dead by then); a writer that lingers is not waited for long.
    pub fn finish(self) -> String {
        match self.done.recv_timeout(Duration::from_secs(2)) {
            Ok((bytes, total)) => shown(&bytes, total),
            Err(_) => "(stderr still open: not read)".into(),
        }
    }
}

/// The end of `bytes` as text, with a note of how much came before.
fn shown(bytes: &[u8], total: u64) -> String {
    let text = String::from_utf8_lossy(bytes);
    let text = text.trim_end();
    let start = text.char_indices().rev().nth(SHOWN_CHARS - 1).map_or(0, |(k, _)| k);
    let cut = start > 0 || total > bytes.len() as u64;
    let note = if cut { format!("(the last lines of {total} bytes)\n") } else { String::new() };
    format!("{note}{}", &text[start..])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_the_end_is_kept() {
        assert_eq!(shown(b"segfault\n", 9), "segfault");
        let long = "x".repeat(3000) + "the end";
        let text = shown(long.as_bytes(), 1 << 30);
        assert!(text.starts_with("(the last lines of 1073741824 bytes)\n") && text.ends_with("the end"));
        assert_eq!(text.lines().nth(1).unwrap().chars().count(), SHOWN_CHARS);
    }
}
