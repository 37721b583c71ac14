//! Long renders that lose nothing: interrupted renders (SIGINT, SIGTERM, SIGKILL after a
//! periodic checkpoint) resume to the uninterrupted image bit for bit; files are never left
//! truncated; checkpoints of other renders and damaged ones are clear errors.
#![cfg(target_os = "linux")]

mod common;

use common::{assert_same_bits, fixture, run, temp_dir};
use pathtracer::io::image::Image;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::OnceLock;
use std::time::{Duration, Instant};

/// The render every interruption test uses: the built-in scene, a few seconds long.
const FLAGS: &[&str] = &["-t", "2", "-s", "384", "-m", "5", "-r", "200", "150"];

fn spawn(args: &[&str]) -> Child {
    Command::new(env!("CARGO_BIN_EXE_pathtracer"))
        .args(args)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("the binary starts")
}

fn signal(child: &Child, sig: &str) {
    let ok = Command::new("kill")
        .args([sig, &child.id().to_string()])
        .status()
        .expect("kill runs")
        .success();
    assert!(ok, "kill {sig} failed");
}

fn args<'a>(extra: &[&'a str]) -> Vec<&'a str> {
    FLAGS.iter().copied().chain(extra.iter().copied()).collect()
}

/// The uninterrupted render, made once.
fn reference() -> &'static Image {
    static REF: OnceLock<Image> = OnceLock::new();
    REF.get_or_init(|| {
        let dir = temp_dir("ckpt-ref");
        let out = dir.join("ref.exr");
        let o = run(&args(&["-f", out.to_str().unwrap()]));
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let img = Image::load(&out).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
        img
    })
}

/// Interrupts a render with `sig` after about a second, checks what it left, resumes it and
/// compares with the uninterrupted render.
fn interrupt_and_resume(sig: &str, tag: &str) {
    let reference = reference();
    let dir = temp_dir(tag);
    let out = dir.join("out.exr");
    let ckpt = dir.join("out.ckpt");
    let child = spawn(&args(&["-f", out.to_str().unwrap()]));
    std::thread::sleep(Duration::from_millis(1000));
    signal(&child, sig);
    let t = Instant::now();
    let o = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(130), "{err}");
    assert!(
        t.elapsed() < Duration::from_secs(3),
        "took {:?} to stop",
        t.elapsed()
    );
    assert!(err.contains("samples per pixel on average"), "{err}");
    assert!(err.contains("--resume"), "{err}");
    // The partial image: some samples, not all.
    let partial = Image::load(&out).unwrap();
    assert_eq!((partial.width, partial.height), (200, 150));
    assert!(partial.mean().x > 0.0);
    assert!(ckpt.is_file());
    let resumed = dir.join("resumed.exr");
    let o = run(&args(&[
        "-f",
        resumed.to_str().unwrap(),
        "--resume",
        ckpt.to_str().unwrap(),
    ]));
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert_same_bits(&Image::load(&resumed).unwrap(), reference);
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn sigint_keeps_the_image_and_resumes_exactly() {
    interrupt_and_resume("-INT", "ckpt-int");
}

#[test]
fn sigterm_keeps_the_image_and_resumes_exactly() {
    interrupt_and_resume("-TERM", "ckpt-term");
}

#[test]
fn sigkill_after_a_periodic_checkpoint_resumes_exactly() {
    let reference = reference();
    let dir = temp_dir("ckpt-kill");
    let out = dir.join("out.exr");
    let ckpt = dir.join("periodic.ckpt");
    let (o, c) = (out.to_str().unwrap(), ckpt.to_str().unwrap());
    let child = spawn(&args(&[
        "-f",
        o,
        "--checkpoint",
        c,
        "--checkpoint-every",
        "0.4",
    ]));
    let t = Instant::now();
    while !ckpt.is_file() && t.elapsed() < Duration::from_secs(20) {
        std::thread::sleep(Duration::from_millis(20));
    }
    std::thread::sleep(Duration::from_millis(500));
    signal(&child, "-KILL");
    let status = child.wait_with_output().unwrap().status;
    assert_eq!(status.code(), None, "the render ended before it was killed");
    assert!(!out.exists(), "no image is written before the end");
    let resumed = dir.join("resumed.exr");
    let o = run(&args(&["-f", resumed.to_str().unwrap(), "--resume", c]));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(err.contains("resuming"), "{err}");
    assert_same_bits(&Image::load(&resumed).unwrap(), reference);
    std::fs::remove_dir_all(&dir).unwrap();
}

/// Files in `dir` other than the output and its temporary files.
fn temp_files(dir: &Path) -> Vec<PathBuf> {
    std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "tmp"))
        .collect()
}

#[test]
fn a_killed_writer_never_leaves_a_truncated_file() {
    let dir = temp_dir("ckpt-write");
    let out = dir.join("big.exr");
    let o = out.to_str().unwrap();
    // A large image that renders fast (emission only), so that much of a run is writing.
    let flags = [
        "-t", "2", "-s", "1", "-m", "0", "-r", "1600", "1200", "-f", o,
    ];
    let t = Instant::now();
    let first = run(&flags);
    assert!(first.status.success());
    let whole = t.elapsed();
    let good = Image::load(&out).unwrap();
    let mut rng = 0x2545_F491_4F6C_DD1Du64;
    let mut killed_while_writing = 0;
    let mut i = 0;
    // Random moments for 12 runs, then (if none of them hit a write) moments right after the
    // temporary file appears, until three kills have hit a write or 40 runs are done.
    while i < 12 || (killed_while_writing < 3 && i < 40) {
        i += 1;
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        let child = spawn(&flags);
        let wait = if i % 2 == 0 && i <= 12 {
            // At a random moment of the run.
            whole.mul_f64((rng % 1000) as f64 / 1000.0 * 1.2)
        } else {
            // Once the temporary file exists: a random moment of the write itself.
            let t = Instant::now();
            while temp_files(&dir).is_empty() && t.elapsed() < whole * 3 {
                std::thread::sleep(Duration::from_micros(200));
            }
            Duration::from_millis(rng % if i > 12 { 3 } else { 12 })
        };
        std::thread::sleep(wait);
        // SAFETY: kill(2) on our own child's pid (not yet reaped) has no memory effects.
        unsafe {
            libc::kill(child.id() as libc::pid_t, libc::SIGKILL);
        }
        let _ = child.wait_with_output();
        // Whatever the moment, the output is a whole image: the old one or the new one.
        let img = Image::load(&out).unwrap_or_else(|e| panic!("after {wait:?}: {e}"));
        assert_eq!(img, good);
        for tmp in temp_files(&dir) {
            killed_while_writing += 1;
            std::fs::remove_file(tmp).unwrap();
        }
    }
    // The test means something only if some kills hit a write in progress.
    assert!(killed_while_writing > 0, "no kill interrupted a write");
    eprintln!("{killed_while_writing} of {i} kills interrupted a write");
    std::fs::remove_dir_all(&dir).unwrap();
}

/// A small finished render with its checkpoint, for the error tests.
fn small_checkpoint(dir: &Path) -> PathBuf {
    let ckpt = dir.join("small.ckpt");
    let out = dir.join("small.png");
    let o = run(&[
        "-s",
        "4",
        "-r",
        "32",
        "24",
        "-f",
        out.to_str().unwrap(),
        "--checkpoint",
        ckpt.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    ckpt
}

fn resume_error(dir: &Path, ckpt: &Path, extra: &[&str]) -> String {
    let out = dir.join("again.png");
    let mut a = vec!["-r", "32", "24", "-f", out.to_str().unwrap()];
    a.extend_from_slice(&["--resume", ckpt.to_str().unwrap()]);
    a.extend_from_slice(extra);
    let o = run(&a);
    assert_eq!(o.status.code(), Some(2));
    assert!(!out.exists(), "no output after an error");
    String::from_utf8_lossy(&o.stderr).into_owned()
}

#[test]
fn resuming_another_render_or_a_damaged_checkpoint_is_a_clear_error() {
    let dir = temp_dir("ckpt-errors");
    let ckpt = small_checkpoint(&dir);
    let c = ckpt.display().to_string();
    // Same flags: fine (the film is complete and is developed again).
    let o = run(&[
        "-s",
        "4",
        "-r",
        "32",
        "24",
        "-f",
        dir.join("same.png").to_str().unwrap(),
        "--resume",
        &c,
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let e = resume_error(&dir, &ckpt, &["-s", "8"]);
    assert!(
        e.contains(&format!("{c}: the checkpoint belongs to another render"))
            && e.contains("spp is 4 in the checkpoint but 8 here"),
        "{e}"
    );
    let e = resume_error(&dir, &ckpt, &["-s", "4", "--seed", "7"]);
    assert!(e.contains("seed is 0 in the checkpoint but 7 here"), "{e}");
    let quad = fixture("quad.dae");
    let e = resume_error(&dir, &ckpt, &["-s", "4", quad.to_str().unwrap()]);
    assert!(
        e.contains("scene is built-in in the checkpoint but quad.dae (sha256"),
        "{e}"
    );
    // Truncated and corrupted checkpoints.
    let bytes = std::fs::read(&ckpt).unwrap();
    let cut = dir.join("cut.ckpt");
    std::fs::write(&cut, &bytes[..bytes.len() * 2 / 3]).unwrap();
    let e = resume_error(&dir, &cut, &["-s", "4"]);
    assert!(
        e.contains(&format!(
            "{}: checksum mismatch: the file is truncated or corrupt",
            cut.display()
        )),
        "{e}"
    );
    let mut bad = bytes.clone();
    bad[bytes.len() / 2] ^= 1;
    std::fs::write(&cut, &bad).unwrap();
    let e = resume_error(&dir, &cut, &["-s", "4"]);
    assert!(e.contains("truncated or corrupt"), "{e}");
    std::fs::write(&cut, b"hello").unwrap();
    let e = resume_error(&dir, &cut, &["-s", "4"]);
    assert!(
        e.contains("not a pathtracer film or checkpoint file"),
        "{e}"
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn an_unwritable_output_directory_fails_before_rendering() {
    let dir = temp_dir("ckpt-unwritable");
    let missing = dir.join("no-such-dir").join("out.png");
    let t = Instant::now();
    // A render that would take minutes: the error must come first.
    let o = run(&["-s", "100000", "-f", missing.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.contains(&format!(
            "{}: cannot write output there: no such directory",
            dir.join("no-such-dir").display()
        )),
        "{e}"
    );
    assert!(t.elapsed() < Duration::from_secs(10));
    // A file where the directory should be.
    std::fs::write(dir.join("file"), b"x").unwrap();
    let o = run(&[
        "-s",
        "1",
        "-f",
        dir.join("file").join("out.png").to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("cannot write output there"));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn a_second_interrupt_ends_at_once_and_leaves_whole_files() {
    let dir = temp_dir("ckpt-twice");
    let out = dir.join("out.exr");
    let child = spawn(&args(&["-f", out.to_str().unwrap()]));
    std::thread::sleep(Duration::from_millis(800));
    signal(&child, "-INT");
    std::thread::sleep(Duration::from_millis(5));
    signal(&child, "-INT");
    let t = Instant::now();
    let o = child.wait_with_output().unwrap();
    assert_eq!(o.status.code(), Some(130));
    assert!(t.elapsed() < Duration::from_secs(2));
    // Whatever got written is whole; a checkpoint, if any, loads.
    if out.exists() {
        let img = Image::load(&out).unwrap();
        assert_eq!((img.width, img.height), (200, 150));
    }
    let ckpt = dir.join("out.ckpt");
    if ckpt.exists() {
        pathtracer::film::Film::load(&ckpt).unwrap();
    }
    std::fs::remove_dir_all(&dir).unwrap();
}
