//! Findings of `cargo fuzz` (issue 12) on the GeoTIFF reader, replayed from
//! their inputs in `tests/data/fuzz/`: each must give a typed error naming
//! the file, and never allocate more than a bound, measured by a counting
//! allocator (the largest single request made by the test's own thread).

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::path::PathBuf;

struct Counting;

thread_local! {
    static LARGEST: Cell<usize> = const { Cell::new(0) };
}

fn note(size: usize) {
    let _ = LARGEST.try_with(|m| {
        if size > m.get() {
            m.set(size)
        }
    });
}

// SAFETY: forwards every call to the system allocator unchanged; the
// thread-local bookkeeping neither allocates nor unwinds.
unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, l: Layout) -> *mut u8 {
        note(l.size());
        unsafe { System.alloc(l) }
    }
    unsafe fn alloc_zeroed(&self, l: Layout) -> *mut u8 {
        note(l.size());
        unsafe { System.alloc_zeroed(l) }
    }
    unsafe fn dealloc(&self, p: *mut u8, l: Layout) {
        unsafe { System.dealloc(p, l) }
    }
    unsafe fn realloc(&self, p: *mut u8, l: Layout, new: usize) -> *mut u8 {
        note(new);
        unsafe { System.realloc(p, l, new) }
    }
}

#[global_allocator]
static ALLOC: Counting = Counting;

fn fuzz_input(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data/fuzz")
        .join(name)
}

/// Open `name` with the default options; the error text and the largest
/// allocation made while opening.
fn open_err(name: &str) -> (String, usize) {
    let p = fuzz_input(name);
    LARGEST.with(|m| m.set(0));
    let r = orogen::io::open_raster(&p, &orogen::io::OpenOptions::default());
    let largest = LARGEST.with(|m| m.get());
    let msg = match r {
        Ok(_) => panic!("{name}: opened a hostile file"),
        Err(e) => e.to_string(),
    };
    (msg, largest)
}

/// A 1 322-byte GeoTIFF whose GeoKeyDirectory tag (34735, SHORT) declares
/// 33 554 432 values: tiff 0.11.3 sized a `Vec<Value>` from the count before
/// reading, 1 GiB (libFuzzer: out-of-memory, `geotiff` target, session 6).
#[test]
fn geotiff_tag_count_beyond_the_file_is_refused_without_allocating_it() {
    let name = "geotiff_geokeys_count_oom.tif";
    assert_eq!(std::fs::metadata(fuzz_input(name)).unwrap().len(), 1322);
    let (msg, largest) = open_err(name);
    assert!(msg.contains(name), "{msg}");
    // The metadata decoder's bound: 1 MiB for a file this small.
    assert!(largest <= 1 << 20, "largest allocation {largest} bytes");
}
