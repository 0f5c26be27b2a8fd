//! The ROM directory (`rom.toml` + `Mr Dr Kr Br Cr [V] .mtx`), from one input in the archive
//! format of the shared code. The matrices are read densely, so the declared-size term of the
//! bound is 8·rows·cols per file. On success the ROM re-validates: shapes agree with its
//! order and I/O lists, every value is finite, and write + read gives it back bit-exactly.
#![no_main]

use libfuzzer_sys::fuzz_target;
use sparsemor::io::rom_dir;
use sparsemor_fuzz::{check_bound, declared_in, input_bytes, measured, unpack, DECLARED_MAX};

const NAMES: &[&str] = &[
    "rom.toml", "Mr.mtx", "Dr.mtx", "Kr.mtx", "Br.mtx", "Cr.mtx", "V.mtx",
];

fuzz_target!(|data: &[u8]| {
    let (dir, files) = unpack(data, NAMES);
    let declared = declared_in(&files, true);
    if declared > DECLARED_MAX {
        return;
    }
    let (result, peak) = measured(|| rom_dir::read(dir.path()));
    check_bound("rom_dir::read", peak, input_bytes(&files), declared);
    let Ok(rom) = result else {
        return;
    };
    let n = rom.order();
    assert_eq!(rom.dofs.len(), n, "dofs list length != order");
    for m in [&rom.mr, &rom.dr, &rom.kr, &rom.br, &rom.cr] {
        assert!((0..m.ncols()).all(|j| (0..m.nrows()).all(|i| m[(i, j)].is_finite())));
    }
    let out = dir.path().join("back");
    rom_dir::write(&out, &rom).expect("write back");
    let again = rom_dir::read(&out).expect("read back");
    for (a, b) in [
        (&rom.mr, &again.mr),
        (&rom.kr, &again.kr),
        (&rom.br, &again.br),
    ] {
        assert_eq!((a.nrows(), a.ncols()), (b.nrows(), b.ncols()));
        assert!((0..a.ncols())
            .all(|j| (0..a.nrows()).all(|i| a[(i, j)].to_bits() == b[(i, j)].to_bits())));
    }
    assert_eq!(rom.dofs, again.dofs);
});
