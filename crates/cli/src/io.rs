//! Input from a file or stdin, output to stdout or a file written atomically.

use std::fs::{self, File};
use std::io::{self, BufRead, BufReader, BufWriter, Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use lampost_gcode::MAX_NUL_RUN;

use crate::report::CliError;

/// Open `path` (`-` is stdin) for buffered reading.
pub fn open_input(path: &str) -> Result<Box<dyn BufRead>, CliError> {
    if path == "-" {
        return Ok(Box::new(BufReader::with_capacity(1 << 16, io::stdin())));
    }
    note_input(path);
    let f = File::open(path).map_err(|e| {
        CliError::usage(format!(
            "error: cannot open {path}: {e}\n  = help: check the path; use - to read standard input"
        ))
    })?;
    Ok(Box::new(BufReader::with_capacity(1 << 16, f)))
}

/// Something to read and seek in.
pub trait ReadSeek: Read + Seek {}
impl<T: Read + Seek> ReadSeek for T {}

fn cannot_open(path: &str, e: &io::Error) -> CliError {
    CliError::usage(format!(
        "error: cannot open {path}: {e}\n  = help: check the path; use - to read standard input"
    ))
}

/// Open `path` for reading and seeking (programs with subprograms are read out of
/// order). Standard input (`-`), or a pipe given by name, is first copied by [`spool`]
/// to a temporary file that is removed as soon as it is open, so memory stays flat.
pub fn open_seekable(path: &str) -> Result<Box<dyn ReadSeek>, CliError> {
    if path != "-" {
        note_input(path);
        let f = File::open(path).map_err(|e| cannot_open(path, &e))?;
        if f.metadata().is_ok_and(|m| m.is_file()) {
            return Ok(Box::new(f));
        }
    }
    let temp = spool(path)?;
    let f = File::open(temp.path())
        .map_err(|e| CliError::usage(format!("error: cannot read {}: {e}", display_name(path))))?;
    Ok(Box::new(f)) // `temp` is dropped: the file loses its name, the handle stays
}

/// Copy standard input (`-`) or a pipe given by name to a temporary file that lives as
/// long as the returned value, for readers that open their input more than once (the
/// post reads a program, then verifies it). Memory stays flat at any size.
pub fn spool(path: &str) -> Result<TempFile, CliError> {
    let mut source: Box<dyn Read> = if path == "-" {
        Box::new(io::stdin().lock())
    } else {
        Box::new(File::open(path).map_err(|e| cannot_open(path, &e))?)
    };
    let (temp, mut f) = TempFile::in_temp_dir("stdin")?;
    copy_text(&mut source, &mut f)
        .and_then(|_| f.flush())
        .map_err(|e| CliError::usage(format!("error: cannot read {}: {e}", display_name(path))))?;
    Ok(temp)
}

/// Copy `from` to `to`, stopping with an error at [`MAX_NUL_RUN`] NUL bytes in a row,
/// at more than one control byte in 16 in its first 64 KiB (binary data is not a
/// program: `/dev/urandom`, an image), or past [`MAX_INPUT_BYTES`] (a device or a pipe
/// that never ends filled the temporary folder at some 300 MB/s).
fn copy_text(from: &mut dyn Read, to: &mut File) -> io::Result<u64> {
    let (mut seen, mut control) = (0usize, 0usize);
    copy_checked(from, MAX_INPUT_BYTES, "not a program", |chunk| {
        if seen < HEAD_BYTES {
            let head = &chunk[..chunk.len().min(HEAD_BYTES - seen)];
            seen += head.len();
            control += head.iter().filter(|&&c| is_binary_byte(c)).count();
            if seen >= 4096 && control * 16 > seen {
                return Err(io::Error::new(
                    io::ErrorKind::InvalidData,
                    format!("{control} control bytes in its first {seen}: binary data, not a program; reading stopped"),
                ));
            }
        }
        to.write_all(chunk)
    })
}

/// How much of a spooled input is looked at for binary data: 64 KiB.
const HEAD_BYTES: usize = 1 << 16;

/// A byte no text program holds: a control character other than tab, line feed, form
/// feed and carriage return (and the tape codes DC1–DC4 and SUB a DNC file may carry).
fn is_binary_byte(c: u8) -> bool {
    matches!(c, 0..=8 | 0x0e..=0x10 | 0x15..=0x19 | 0x1b..=0x1f | 0x7f)
}

/// The most bytes an input read whole (a mesh, a per-point path, a log, a point file, a
/// machine, setup or job file) is read to: 2 GiB. A program is streamed instead.
pub const MAX_INPUT_BYTES: u64 = 2 << 30;

/// `from` read to its end into `out`, as `Read::read_to_end` reads it, but stopping with
/// an `InvalidData` error at [`MAX_NUL_RUN`] NUL bytes in a row (binary data, or a
/// device such as `/dev/zero`, which never ends) or past [`MAX_INPUT_BYTES`]: no input
/// read whole makes a command hang or fill the memory.
pub fn read_to_end_checked(from: &mut dyn Read, out: &mut Vec<u8>) -> io::Result<usize> {
    read_checked(from, out, MAX_INPUT_BYTES)
}

/// [`read_to_end_checked`] as text, as `Read::read_to_string` reads it (not UTF-8: an
/// `InvalidData` error).
pub fn read_to_string_checked(from: &mut dyn Read, out: &mut String) -> io::Result<usize> {
    let mut bytes = Vec::new();
    let n = read_to_end_checked(from, &mut bytes)?;
    let text = String::from_utf8(bytes).map_err(|_| {
        io::Error::new(
            io::ErrorKind::InvalidData,
            "stream did not contain valid UTF-8",
        )
    })?;
    if out.is_empty() {
        *out = text;
    } else {
        out.push_str(&text);
    }
    Ok(n)
}

/// The file at `path` read whole by [`read_to_end_checked`] (as `fs::read` reads it).
pub fn read_file(path: impl AsRef<Path>) -> io::Result<Vec<u8>> {
    note_input(path.as_ref());
    let mut out = Vec::new();
    read_to_end_checked(&mut File::open(path)?, &mut out)?;
    Ok(out)
}

/// The file at `path` read whole as text by [`read_to_string_checked`] (as
/// `fs::read_to_string` reads it).
pub fn read_file_to_string(path: impl AsRef<Path>) -> io::Result<String> {
    note_input(path.as_ref());
    read_settings_file(path)
}

/// [`read_file_to_string`] for a machine file, which a run may rewrite in place
/// (`lampost calibrate pivot --machine m.toml --write m.toml`): not noted as an input
/// that no output may replace.
pub fn read_settings_file(path: impl AsRef<Path>) -> io::Result<String> {
    let mut out = String::new();
    read_to_string_checked(&mut File::open(path)?, &mut out)?;
    Ok(out)
}

/// The files this run reads (their canonical paths), each with its length and time of
/// change when first noted: no output is put in their place, and no output is put in
/// place at all once one of them has changed ([`persist_set`] refuses both), so `trace
/// in.nc -o in.nc` cannot destroy its program, and a program cut short while it was read
/// (a copy still being written) is not posted as a shorter program.
static INPUTS: std::sync::Mutex<Vec<(PathBuf, Stamp)>> = std::sync::Mutex::new(Vec::new());

/// A file's length and time of last change.
type Stamp = (u64, Option<std::time::SystemTime>);

fn stamp(m: &fs::Metadata) -> Stamp {
    (m.len(), m.modified().ok())
}

/// Note `path` as an input of this run (a regular file; stdin and devices are not).
pub fn note_input(path: impl AsRef<Path>) {
    let p = path.as_ref();
    let Ok(m) = fs::metadata(p) else {
        return;
    };
    if p.as_os_str() == "-" || !m.is_file() {
        return;
    }
    if let Ok(c) = p.canonicalize() {
        let mut inputs = INPUTS
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        if !inputs.iter().any(|(q, _)| *q == c) {
            inputs.push((c, stamp(&m)));
        }
    }
}

/// Whether `target` is a file this run read (see [`note_input`]).
fn is_input(target: &Path) -> bool {
    target.canonicalize().is_ok_and(|c| {
        INPUTS
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .iter()
            .any(|(q, _)| *q == c)
    })
}

/// The first input of this run that has changed (or gone) since it was noted: its path,
/// and what it was and is.
fn changed_input() -> Option<(PathBuf, String)> {
    let inputs = INPUTS
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    inputs.iter().find_map(|(p, was)| {
        let now = fs::metadata(p).ok().map(|m| stamp(&m));
        match now {
            Some(now) if now == *was => None,
            Some((len, _)) if len != was.0 => Some((
                p.clone(),
                format!("{} bytes when it was opened, {len} now", was.0),
            )),
            Some(_) => Some((p.clone(), "written to while it was read".into())),
            None => Some((p.clone(), "removed while it was read".into())),
        }
    })
}

/// The files this run writes (absolute paths, their folders resolved), as their
/// temporary files are made.
static OUTPUTS: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());

/// Note `real` (the output named `given`) as an output of this run, returning the key it
/// is noted by; refused when it is one already. A temporary file dropped unplaced forgets
/// its key ([`forget_output`]): a run may remake an output it has not written.
fn note_output(real: &Path, given: &str) -> Result<PathBuf, CliError> {
    let dir = real
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let key = match (dir.canonicalize(), real.file_name()) {
        (Ok(d), Some(n)) => d.join(n),
        _ => real.to_path_buf(),
    };
    let mut outputs = OUTPUTS
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    if outputs.contains(&key) {
        return Err(CliError::usage(format!(
            "error: {given} is named as two outputs of this run: one would replace the other\n  = help: give each output its own path\n"
        )));
    }
    outputs.push(key.clone());
    Ok(key)
}

/// Forget `key` as an output of this run (its temporary file was dropped, not placed).
fn forget_output(key: &Path) {
    OUTPUTS
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
        .retain(|k| k != key);
}

/// Where an output named `target` goes: through a symbolic link to the file it names
/// (`-o link` writes the file, not a new file in the link's place; `-o /dev/stdout` is
/// the run's standard output), else `target`.
fn real_target(target: &Path) -> PathBuf {
    if fs::symlink_metadata(target).is_ok_and(|m| m.file_type().is_symlink()) {
        if let Ok(c) = target.canonicalize() {
            return c;
        }
        // A link to a file not there yet: the file it names is made (the link kept),
        // one level followed.
        if let Ok(to) = fs::read_link(target) {
            return match target.parent() {
                Some(dir) if to.is_relative() => dir.join(to),
                _ => to,
            };
        }
    }
    target.to_path_buf()
}

/// [`read_to_end_checked`] with the bound on size given.
fn read_checked(from: &mut dyn Read, out: &mut Vec<u8>, limit: u64) -> io::Result<usize> {
    let start = out.len();
    copy_checked(from, limit, "not an input lampost reads", |chunk| {
        out.extend_from_slice(chunk);
        Ok(())
    })?;
    Ok(out.len() - start)
}

/// Copy `from` to `sink` in pieces, stopping with an `InvalidData` error at
/// [`MAX_NUL_RUN`] NUL bytes in a row (binary data, `what` it is not) or when more than
/// `limit` bytes come.
fn copy_checked(
    from: &mut dyn Read,
    limit: u64,
    what: &str,
    mut sink: impl FnMut(&[u8]) -> io::Result<()>,
) -> io::Result<u64> {
    let mut buf = vec![0u8; 1 << 16];
    let (mut total, mut run) = (0u64, 0usize);
    loop {
        let n = match from.read(&mut buf) {
            Ok(0) => return Ok(total),
            Ok(n) => n,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(e),
        };
        let chunk = &buf[..n];
        // The run carried over goes on through the chunk's leading NULs.
        let leading = chunk.iter().position(|&c| c != 0).unwrap_or(n);
        let through = run.saturating_add(leading);
        run = match chunk.iter().rposition(|&c| c != 0) {
            Some(i) => n - 1 - i,
            None => through,
        };
        if run.max(through) >= MAX_NUL_RUN {
            return Err(io::Error::new(
                io::ErrorKind::InvalidData,
                format!(
                    "{MAX_NUL_RUN} NUL bytes in a row (byte {} on): binary data, {what}; reading stopped",
                    (total + n as u64).saturating_sub(run as u64)
                ),
            ));
        }
        if total + n as u64 > limit {
            return Err(io::Error::new(
                io::ErrorKind::InvalidData,
                format!(
                    "more than {limit} bytes: larger than lampost reads whole; reading stopped"
                ),
            ));
        }
        sink(chunk)?;
        total += n as u64;
    }
}

/// Several files read one after another as one input, seekable: DNC pieces given in
/// order. A file that does not end in a line break gets one, so no two lines run
/// together. One file is open at a time.
#[derive(Debug)]
pub struct Concat {
    /// Each file, its length, and whether a line break is added after it.
    parts: Vec<(PathBuf, u64, bool)>,
    /// Where each part starts in the whole.
    starts: Vec<u64>,
    total: u64,
    pos: u64,
    open: Option<(usize, File)>,
}

impl Concat {
    /// The files `paths`, in order.
    pub fn open(paths: &[String]) -> Result<Self, CliError> {
        for p in paths {
            note_input(p);
        }
        let mut parts = Vec::with_capacity(paths.len());
        let mut starts = Vec::with_capacity(paths.len());
        let mut total = 0u64;
        for p in paths {
            let mut f = File::open(p).map_err(|e| cannot_open(p, &e))?;
            let meta = f.metadata().map_err(|e| cannot_open(p, &e))?;
            if !meta.is_file() {
                return Err(CliError::usage(format!(
                    "error: {p} is not a file: pieces read together are opened again as they are read\n"
                )));
            }
            let len = meta.len();
            let mut last = [b'\n'];
            if len > 0 {
                f.seek(SeekFrom::Start(len - 1))
                    .and_then(|_| f.read_exact(&mut last))
                    .map_err(|e| cannot_open(p, &e))?;
            }
            let add = last[0] != b'\n';
            starts.push(total);
            total += len + u64::from(add);
            parts.push((PathBuf::from(p), len, add));
        }
        Ok(Concat {
            parts,
            starts,
            total,
            pos: 0,
            open: None,
        })
    }

    /// The file holding byte `offset` of the whole, and the offset where it starts.
    pub fn part_at(&self, offset: u64) -> Option<(usize, u64)> {
        let k = self
            .starts
            .partition_point(|&s| s <= offset)
            .checked_sub(1)?;
        Some((k, self.starts[k]))
    }
}

impl Read for Concat {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        if buf.is_empty() || self.pos >= self.total {
            return Ok(0);
        }
        let Some((k, start)) = self.part_at(self.pos) else {
            return Ok(0);
        };
        let (path, len, _) = &self.parts[k];
        let within = self.pos - start;
        if within >= *len {
            // The added line break.
            buf[0] = b'\n';
            self.pos += 1;
            return Ok(1);
        }
        if self.open.as_ref().is_none_or(|(i, _)| *i != k) {
            self.open = Some((k, File::open(path)?));
        }
        let Some((_, f)) = self.open.as_mut() else {
            return Ok(0);
        };
        f.seek(SeekFrom::Start(within))?;
        let want = usize::try_from(len - within)
            .unwrap_or(usize::MAX)
            .min(buf.len());
        let n = f.read(&mut buf[..want])?;
        self.pos += n as u64;
        Ok(n)
    }
}

impl Seek for Concat {
    fn seek(&mut self, to: SeekFrom) -> io::Result<u64> {
        let target = match to {
            SeekFrom::Start(p) => i128::from(p),
            SeekFrom::Current(d) => i128::from(self.pos) + i128::from(d),
            SeekFrom::End(d) => i128::from(self.total) + i128::from(d),
        };
        self.pos = u64::try_from(target)
            .map_err(|_| io::Error::new(io::ErrorKind::InvalidInput, "seek before the start"))?;
        Ok(self.pos)
    }
}

/// The name used for `path` in messages.
pub fn display_name(path: &str) -> String {
    if path == "-" {
        "<stdin>".to_string()
    } else {
        path.to_string()
    }
}

/// What a run has made and not yet put in place: temporary files, and folders it
/// created for its output. Removed if the process is interrupted (SIGINT, SIGTERM,
/// SIGHUP), so no run leaves one behind. Files are registered under the lock before
/// they are created, and the handler keeps the lock until the process exits, so no file
/// is made after it has looked.
#[derive(Default)]
struct Live {
    files: Vec<PathBuf>,
    dirs: Vec<PathBuf>,
}

/// Set by the interrupt handler before it takes [`LIVE`]'s lock.
static INTERRUPTED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

static LIVE: std::sync::Mutex<Live> = std::sync::Mutex::new(Live {
    files: Vec::new(),
    dirs: Vec::new(),
});

fn live() -> std::sync::MutexGuard<'static, Live> {
    LIVE.lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// On SIGINT, SIGTERM or SIGHUP: remove every temporary file alive and every folder
/// this run created that is then empty, then exit with 130. A set of files being put in
/// place ([`persist_set`]) is finished first.
pub fn remove_temps_on_signal() {
    let _ = ctrlc::set_handler(|| {
        // Said before the lock is taken: a write into a full pipe under it gives up.
        INTERRUPTED.store(true, std::sync::atomic::Ordering::Relaxed);
        let mut live = live();
        for p in live.files.drain(..) {
            let _ = fs::remove_file(p);
        }
        for d in live.dirs.drain(..).rev() {
            let _ = fs::remove_dir(d);
        }
        // Exits with the lock held: no thread registers (or makes) a file after this.
        std::process::exit(130);
    });
}

/// A folder made for a run's output: removed again (when empty) if the run fails or is
/// interrupted, unless [`NewDir::keep`] is called; a folder that was there is left
/// alone.
#[derive(Debug)]
pub struct NewDir {
    made: Option<PathBuf>,
}

impl NewDir {
    /// Make `dir` (and its parents) unless it exists.
    pub fn create(dir: &Path) -> io::Result<NewDir> {
        if dir.is_dir() {
            return Ok(NewDir { made: None });
        }
        let mut live = live();
        fs::create_dir_all(dir)?;
        live.dirs.push(dir.to_path_buf());
        Ok(NewDir {
            made: Some(dir.to_path_buf()),
        })
    }

    /// The run succeeded: the folder stays.
    pub fn keep(mut self) {
        if let Some(d) = self.made.take() {
            live().dirs.retain(|p| p != &d);
        }
    }
}

impl Drop for NewDir {
    fn drop(&mut self) {
        if let Some(d) = self.made.take() {
            let _ = fs::remove_dir(&d);
            live().dirs.retain(|p| p != &d);
        }
    }
}

/// Write each text to its file (`-` or `None`: standard output, after the files) as one
/// set ([`persist_set`]): every file is staged before any is placed, so a refusal (one
/// path named twice, an input's path) or a failure leaves every target as it was.
pub fn write_set(files: &[(Option<&str>, &[u8])]) -> Result<(), CliError> {
    let mut staged = Vec::new();
    let mut to_stdout = Vec::new();
    for &(target, text) in files {
        match target {
            None | Some("-") => to_stdout.push(text),
            Some(t) => {
                let (temp, mut f) = TempFile::beside(Some(t))?;
                f.write_all(text)
                    .and_then(|()| f.flush())
                    .map_err(|e| cannot_write(Path::new(t), &e))?;
                staged.push((temp, PathBuf::from(t)));
            }
        }
    }
    persist_set(staged, None, || {})?;
    for text in to_stdout {
        let mut o = Output::create(None)?;
        o.writer()
            .write_all(text)
            .map_err(|e| CliError::write(&e))?;
        o.commit()?;
    }
    Ok(())
}

/// Put a set of temporary files in place, in the order given, as one step: an interrupt
/// arriving meanwhile waits until every file is renamed, so the set is left entirely old
/// or entirely new. `first` (a file that names the set, such as a manifest) is removed
/// before any rename, so a folder a crash leaves half updated has none; `after` runs
/// within the step once every rename succeeded (to remove what the set replaces). On an
/// error the files not yet in place are removed.
pub fn persist_set(
    files: Vec<(TempFile, PathBuf)>,
    first: Option<&Path>,
    after: impl FnOnce(),
) -> Result<(), CliError> {
    let mut live = live();
    let mut done = first.map_or(Ok(()), |p| match fs::remove_file(p) {
        Err(e) if e.kind() != io::ErrorKind::NotFound => Err(cannot_write(p, &e)),
        _ => Ok(()),
    });
    if done.is_ok() {
        if let Some((input, what)) = changed_input() {
            done = Err(CliError::failed(format!(
                "error: {}: the input changed while this run read it ({what}): what was read may be cut short or mixed, and nothing is written\n  = help: let whatever writes the file finish, then run again\n",
                input.display()
            )));
        }
    }
    if done.is_ok() {
        if let Some((_, target)) = files.iter().find(|(_, t)| is_input(t)) {
            done = Err(CliError::usage(format!(
                "error: {}: the same file as an input of this run: writing it would destroy the input\n  = help: write the output to another path\n",
                target.display()
            )));
        }
    }
    for (t, target) in files {
        // Its removal is done here, under the lock (a drop would take it again).
        let path = t.into_path();
        if done.is_ok() {
            done = place(&path, &target).map_err(|e| cannot_write(&target, &e));
            commit_pause();
        }
        if done.is_err() || path.exists() {
            let _ = fs::remove_file(&path);
        }
        live.files.retain(|p| p != &path);
    }
    if done.is_ok() {
        after();
    }
    done
}

/// Test builds only: `LAMPOST_TEST_COMMIT_PAUSE_MS` slows [`persist_set`] down between
/// renames, so a test can interrupt it in the middle.
fn commit_pause() {
    #[cfg(debug_assertions)]
    if let Some(ms) = std::env::var("LAMPOST_TEST_COMMIT_PAUSE_MS")
        .ok()
        .and_then(|v| v.parse::<u64>().ok())
    {
        std::thread::sleep(std::time::Duration::from_millis(ms));
    }
}

fn cannot_write(target: &Path, e: &io::Error) -> CliError {
    CliError::usage(format!("error: cannot write {}: {e}\n", target.display()))
}

/// Rename `path` over `target`; a device or a pipe (`/dev/null`, a FIFO) gets its
/// contents written to it instead (a rename would replace the device with a file), and
/// `path` stays for the caller to remove.
fn place(path: &Path, target: &Path) -> io::Result<()> {
    let target = &real_target(target);
    if fs::metadata(target).is_ok_and(|m| {
        use std::os::unix::fs::FileTypeExt;
        m.file_type().is_fifo()
    }) {
        return write_fifo(path, target);
    }
    if is_special(target) {
        let mut from = File::open(path)?;
        let mut to = fs::OpenOptions::new().write(true).open(target)?;
        io::copy(&mut from, &mut to)?;
        return to.flush();
    }
    fs::rename(path, target)
}

/// Write the file at `path` into the FIFO (or pipe) `target` without ever blocking: a
/// blocking open waits for a reader without end, and it and a blocking write wait under
/// the lock an interrupt needs ([`persist_set`]), so that SIGINT and SIGTERM went
/// unheard. Opened non-blocking, a FIFO no process reads is refused at once (ENXIO); a
/// full pipe is waited on in short sleeps that an interrupt ends.
fn write_fifo(path: &Path, target: &Path) -> io::Result<()> {
    use std::io::Read;
    use std::os::unix::fs::OpenOptionsExt;
    let mut to = match fs::OpenOptions::new()
        .write(true)
        .custom_flags(libc::O_NONBLOCK)
        .open(target)
    {
        Err(e) if e.raw_os_error() == Some(libc::ENXIO) => {
            return Err(io::Error::other(
                "it is a FIFO (named pipe) that no process is reading: start the program that reads it first, or write to a file",
            ))
        }
        r => r?,
    };
    let mut from = File::open(path)?;
    let mut buf = vec![0u8; 1 << 16];
    loop {
        let n = from.read(&mut buf)?;
        if n == 0 {
            return Ok(());
        }
        let mut chunk = &buf[..n];
        while !chunk.is_empty() {
            match to.write(chunk) {
                Ok(0) => return Err(io::Error::from(io::ErrorKind::WriteZero)),
                Ok(k) => chunk = &chunk[k..],
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => {
                    if INTERRUPTED.load(std::sync::atomic::Ordering::Relaxed) {
                        return Err(io::Error::from(io::ErrorKind::Interrupted));
                    }
                    std::thread::sleep(std::time::Duration::from_millis(2));
                }
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
                Err(e) => return Err(e),
            }
        }
    }
}

/// Whether `path` names something that is not a regular file or a folder: a character
/// or block device, a FIFO or a socket (following symbolic links, so `/dev/stdout` too).
pub fn is_special(path: &Path) -> bool {
    fs::metadata(path).is_ok_and(|m| !m.is_file() && !m.is_dir())
}

/// The one temporary-file helper: a file created beside its target (for standard
/// output, in the temporary folder), removed when dropped, on an interrupt, or on any
/// error; [`TempFile::persist`] renames it over the target.
#[derive(Debug)]
pub struct TempFile {
    path: PathBuf,
    /// The output it is for, as noted ([`note_output`]); forgotten when dropped unplaced.
    output: Option<PathBuf>,
}

impl TempFile {
    /// A new, empty temporary file for `target` (`None` or `-`: standard output). A
    /// file named as two outputs of one run (`--svg x --csv x`) is refused at the second:
    /// one would silently replace the other.
    pub fn beside(target: Option<&str>) -> Result<(TempFile, File), CliError> {
        let real = target
            .filter(|t| *t != "-")
            .map(|t| real_target(Path::new(t)));
        let output = match real.as_deref().filter(|r| !is_special(r)) {
            Some(r) => Some(note_output(r, target.unwrap_or_default())?),
            None => None,
        };
        let target = real.as_deref().and_then(Path::to_str);
        let dir = match target {
            // A device or a pipe (`-o /dev/null`) is written through, never renamed over:
            // its temporary file lives in the temporary folder.
            Some(t) if is_special(Path::new(t)) => std::env::temp_dir(),
            // A bare name: its folder is the current one (a rename never crosses file
            // systems).
            Some(t) => Path::new(t)
                .parent()
                .filter(|d| !d.as_os_str().is_empty())
                .map_or_else(|| PathBuf::from("."), Path::to_path_buf),
            None => std::env::temp_dir(),
        };
        let name = target
            .and_then(|t| Path::new(t).file_name())
            .map_or_else(|| "stdout".into(), |n| n.to_string_lossy().into_owned());
        let made = Self::create(&dir, &name);
        match made {
            Ok((mut t, f)) => {
                t.output = output;
                Ok((t, f))
            }
            Err(e) => {
                if let Some(k) = &output {
                    forget_output(k);
                }
                Err(e)
            }
        }
    }

    /// A new, empty temporary file in the temporary folder, its name made from `name`.
    pub fn in_temp_dir(name: &str) -> Result<(TempFile, File), CliError> {
        Self::create(&std::env::temp_dir(), name)
    }

    fn create(dir: &Path, name: &str) -> Result<(TempFile, File), CliError> {
        remove_stale(dir, name);
        let mut k = 0u32;
        // Registered before it exists (see [`Live`]).
        let mut live = live();
        loop {
            let path = dir.join(format!(".{name}.{}.{k}.tmp", std::process::id()));
            match fs::OpenOptions::new()
                .read(true)
                .write(true)
                .create_new(true)
                .open(&path)
            {
                Ok(f) => {
                    live.files.push(path.clone());
                    return Ok((TempFile { path, output: None }, f));
                }
                Err(e) if e.kind() == io::ErrorKind::AlreadyExists && k < 1000 => k += 1,
                Err(e) => {
                    return Err(CliError::usage(format!(
                        "error: cannot write {}: {e}\n  = help: check that the folder exists and is writable",
                        path.display()
                    )))
                }
            }
        }
    }

    /// Its path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Rename it over `target`; a device or a pipe (`/dev/null`, a FIFO) gets its
    /// contents written to it instead (a rename would replace the device with a file).
    pub fn persist(self, target: &Path) -> Result<(), CliError> {
        persist_set(vec![(self, target.to_path_buf())], None, || {})
    }

    /// Its path, no longer removed when dropped (still registered in [`Live`]).
    fn into_path(self) -> PathBuf {
        let path = self.path.clone();
        std::mem::forget(self);
        path
    }
}

/// Remove the temporary files for `name` in `dir` that a run killed outright (SIGKILL,
/// a power cut: no handler runs) left: `.NAME.PID.K.tmp` whose process is gone (no
/// `/proc/PID`; where `/proc` is not there, nothing is removed). A live process's,
/// or another name's, is never touched.
fn remove_stale(dir: &Path, name: &str) {
    if !Path::new("/proc/self").exists() {
        return;
    }
    let Ok(entries) = fs::read_dir(dir) else {
        return;
    };
    let prefix = format!(".{name}.");
    for e in entries.flatten() {
        let file = e.file_name();
        let Some(rest) = file
            .to_str()
            .and_then(|f| f.strip_prefix(&prefix))
            .and_then(|r| r.strip_suffix(".tmp"))
        else {
            continue;
        };
        // `PID.K`, both numbers.
        let Some((pid, k)) = rest.split_once('.') else {
            continue;
        };
        let numbers = |t: &str| !t.is_empty() && t.bytes().all(|b| b.is_ascii_digit());
        if !(numbers(pid) && numbers(k)) || pid == std::process::id().to_string() {
            continue;
        }
        if !Path::new("/proc").join(pid).exists() && e.file_type().is_ok_and(|t| t.is_file()) {
            let _ = fs::remove_file(e.path());
        }
    }
}

impl Drop for TempFile {
    fn drop(&mut self) {
        if let Some(k) = &self.output {
            forget_output(k);
        }
        let mut live = live();
        let _ = fs::remove_file(&self.path);
        live.files.retain(|p| p != &self.path);
    }
}

/// Where output goes: stdout, or a temporary file beside the target that is renamed
/// over it only on [`Output::commit`]; dropped uncommitted, the temporary file is
/// removed, so a failed run never leaves a half-written file.
pub struct Output {
    writer: Option<BufWriter<Box<dyn Write>>>,
    temp: Option<TempFile>,
    target: Option<PathBuf>,
}

impl std::fmt::Debug for Output {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Output")
            .field("target", &self.target)
            .finish()
    }
}

impl Output {
    /// Output to `path`, or stdout for `None` or `-`.
    pub fn create(path: Option<&str>) -> Result<Self, CliError> {
        match path {
            None | Some("-") => Ok(Output {
                writer: Some(BufWriter::with_capacity(
                    1 << 16,
                    Box::new(io::stdout().lock()),
                )),
                temp: None,
                target: None,
            }),
            Some(p) => {
                let (temp, f) = TempFile::beside(Some(p))?;
                Ok(Output {
                    writer: Some(BufWriter::with_capacity(1 << 16, Box::new(f))),
                    temp: Some(temp),
                    target: Some(PathBuf::from(p)),
                })
            }
        }
    }

    /// The writer.
    pub fn writer(&mut self) -> &mut dyn Write {
        match self.writer.as_mut() {
            Some(w) => w,
            None => unreachable_writer(),
        }
    }

    /// Flush and, for a file, rename the temporary file over the target.
    pub fn commit(mut self) -> Result<(), CliError> {
        if let Some(mut w) = self.writer.take() {
            w.flush().map_err(|e| match &self.target {
                Some(t) if e.kind() != io::ErrorKind::BrokenPipe => cannot_write(t, &e),
                _ => CliError::write(&e),
            })?;
        }
        if let (Some(temp), Some(target)) = (self.temp.take(), self.target.take()) {
            temp.persist(&target)?;
        }
        Ok(())
    }
}

fn unreachable_writer() -> &'static mut dyn Write {
    // After commit the writer is gone; writes then go nowhere.
    Box::leak(Box::new(io::sink()))
}

impl Drop for Output {
    fn drop(&mut self) {
        // The writer first (it holds the file), then the temporary file goes.
        self.writer.take();
        self.temp.take();
    }
}

/// Where `path` leads, for telling files apart: its canonical path, or (not there yet)
/// its folder's with its name; `None` for standard input or output (`-`) and for a
/// folder that is not there.
fn identity(path: &str) -> Option<PathBuf> {
    if path == "-" {
        return None;
    }
    let p = Path::new(path);
    if let Ok(c) = p.canonicalize() {
        return Some(c);
    }
    let dir = p
        .parent()
        .filter(|d| !d.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    Some(dir.canonicalize().ok()?.join(p.file_name()?))
}

/// Outputs (`(flag, path)`) that would overwrite each other or an input (`(what, path)`)
/// are refused before anything is read: `--json-report` at `-o`'s path replaced the
/// posted program, and `-o` at the input's replaced the input.
pub fn distinct_outputs(
    outputs: &[(&str, Option<&str>)],
    inputs: &[(&str, Option<&str>)],
) -> Result<(), CliError> {
    let outs: Vec<(&str, &str, PathBuf)> = outputs
        .iter()
        .filter_map(|&(f, p)| p.and_then(|p| identity(p).map(|i| (f, p, i))))
        .collect();
    for (k, (flag, path, id)) in outs.iter().enumerate() {
        if let Some((other, _, _)) = outs[..k].iter().find(|o| o.2 == *id) {
            return Err(CliError::usage(format!(
                "error: {flag} {path}: the same file as {other}'s: one would overwrite the other\n  = help: give each output its own path\n"
            )));
        }
        if let Some((what, _)) = inputs
            .iter()
            .find(|(_, p)| p.and_then(identity).is_some_and(|i| i == *id))
        {
            return Err(CliError::usage(format!(
                "error: {flag} {path}: the same file as the {what}: writing it would destroy the {what}\n  = help: write the output to another path\n"
            )));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A reader that never ends: `byte` forever.
    struct Endless(u8);

    impl Read for Endless {
        fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
            buf.fill(self.0);
            Ok(buf.len())
        }
    }

    #[test]
    fn an_endless_input_stops_at_a_nul_run_or_the_size_bound() {
        let mut out = Vec::new();
        let e = read_to_end_checked(&mut Endless(0), &mut out).expect_err("stops");
        assert_eq!(e.kind(), io::ErrorKind::InvalidData);
        assert!(e.to_string().contains("NUL bytes in a row"), "{e}");
        let mut out = Vec::new();
        let e = read_checked(&mut Endless(b'1'), &mut out, 1 << 20).expect_err("stops");
        assert!(e.to_string().contains("more than 1048576 bytes"), "{e}");
        assert!(out.len() <= 1 << 20);
    }

    #[test]
    fn a_file_reads_as_the_standard_readers_read_it() {
        let text = "x y z i j k feed laser\n1 2 3 0 0 1 600 1\n";
        let mut s = String::new();
        read_to_string_checked(&mut text.as_bytes(), &mut s).expect("reads");
        assert_eq!(s, text);
        let bad = [b'a', 0xff, b'b'];
        let e = read_to_string_checked(&mut &bad[..], &mut String::new()).expect_err("not UTF-8");
        assert_eq!(e.kind(), io::ErrorKind::InvalidData);
        // A run spanning two reads is one run: 65,535 NULs at the end of one read and
        // 65,535 at the start of the next.
        struct Two(Vec<Vec<u8>>);
        impl Read for Two {
            fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
                match self.0.first().cloned() {
                    Some(c) => {
                        self.0.remove(0);
                        buf[..c.len()].copy_from_slice(&c);
                        Ok(c.len())
                    }
                    None => Ok(0),
                }
            }
        }
        let mut a = vec![0u8; MAX_NUL_RUN];
        a[0] = b'x';
        let mut b = vec![0u8; MAX_NUL_RUN];
        b[MAX_NUL_RUN - 1] = b'x';
        let e = read_to_end_checked(&mut Two(vec![a, b]), &mut Vec::new()).expect_err("a run");
        assert!(e.to_string().contains("NUL bytes in a row"), "{e}");
        // NUL bytes short of the run are data.
        let mut v = vec![0u8; MAX_NUL_RUN - 1];
        v.push(1);
        let mut out = Vec::new();
        assert_eq!(
            read_to_end_checked(&mut &v[..], &mut out).expect("reads"),
            v.len()
        );
        assert_eq!(out, v);
    }
}
