//! Memory freed by a thread that has ended is given back to the system by `memory::release_freed`
//! (glibc keeps it in that thread's arena otherwise). Its own test binary: resident memory is
//! measured, and no other test may allocate meanwhile.

use shellwarp::memory::{release_freed, resident_bytes};

#[test]
#[cfg(all(target_os = "linux", target_env = "gnu"))]
fn memory_a_finished_thread_freed_goes_back_to_the_system() {
    const CHUNK: usize = 64 * 1024; // below glibc's mmap threshold: from the thread's arena
    const CHUNKS: usize = 3200; // 210 MB
    // The thread's last allocation, at its arena's top, lives on here: plain `free` cannot shrink
    // the arena past it, so the chunks freed below it stay resident until released.
    let keeper = std::thread::spawn(|| {
        let chunks: Vec<Vec<u8>> = (0..CHUNKS).map(|i| vec![i as u8 | 1; CHUNK]).collect();
        let keeper = vec![1u8; CHUNK];
        drop(chunks);
        keeper
    })
    .join()
    .unwrap();
    let held = resident_bytes();
    release_freed();
    let released = resident_bytes();
    eprintln!("resident {:.0} MB before the release, {:.0} MB after", held as f64 / 1e6, released as f64 / 1e6);
    assert!(held >= released + 100_000_000, "{held} → {released} bytes");
    drop(keeper);
}
