//! Spectra files through `read_spectra_csv`: a good file parses, and every bad one is an
//! error whose message starts with the file's path (and the line, where there is one).

use std::path::PathBuf;

use colorimetry::{Error, read_spectra_csv};

/// Write `text` to a file of this name in the test binary's scratch folder
/// (`CARGO_TARGET_TMPDIR`, under `target/`, kept between runs and never committed).
fn write(name: &str, text: &str) -> PathBuf {
    let path = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("colorimetry-csv").join(name);
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn a_good_file_parses_with_its_column_names() {
    let path = write("good.csv", "wavelength_nm,flat,ramp\n400,0.5,0.1\n410,0.5,0.2\n420,0.5,0.3\n");
    let table = read_spectra_csv(&path).unwrap();
    let names: Vec<&str> = table.iter().map(|s| s.name.as_str()).collect();
    assert_eq!(names, ["flat", "ramp"]);
    // Linear between rows: halfway from 0.2 to 0.3 at 415 nm, to one rounding.
    assert!((table[1].spectrum.eval(415.0) - 0.25).abs() < 1e-15);
}

#[test]
fn a_missing_file_is_an_io_error_naming_it() {
    let path = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("colorimetry-csv").join("no-such-spectra.csv");
    let err = read_spectra_csv(&path).unwrap_err();
    assert!(
        matches!(&err, Error::Io { path: p, source } if *p == path.display().to_string()
            && source.kind() == std::io::ErrorKind::NotFound),
        "{err:?}"
    );
    assert_eq!(err.to_string(), format!("{}: cannot read file", path.display()));
    // The OS reason is the error's source, so a chain report (anyhow's `{:#}`) states it once.
    assert!(std::error::Error::source(&err).is_some());
}

#[test]
fn each_bad_file_is_an_error_naming_the_file_and_line() {
    let cases: [(&str, &str, &str); 7] = [
        (
            "unsorted.csv",
            "wavelength_nm,a\n400,1\n550,1\n545,1\n",
            ":4: wavelength 545 nm after 550 nm (must increase)",
        ),
        ("duplicate.csv", "wavelength_nm,a\n400,1\n400,1\n", ":3: wavelength 400 nm after 400 nm (must increase)"),
        ("not_a_number.csv", "wavelength_nm,a\n400,0.5\n410,abc\n", ":3: column `a`: `abc` is not a number"),
        ("nan.csv", "wavelength_nm,a\n400,NaN\n", ":2: column `a`: NaN is not finite"),
        (
            "negative.csv",
            "wavelength_nm,a\n400,0.5\n410,-0.1\n",
            ":3: column `a`: -0.1 is negative (spectra must be >= 0)",
        ),
        ("ragged.csv", "wavelength_nm,a\n400,1,2\n", ":2: 3 cells, the header has 2"),
        ("header_only.csv", "wavelength_nm,a\n", ": no data"),
    ];
    for (name, text, message) in cases {
        let path = write(name, text);
        let err = read_spectra_csv(&path).unwrap_err();
        assert_eq!(err.to_string(), format!("{}{message}", path.display()), "{name}");
    }
    let empty = write("empty.csv", "");
    assert!(matches!(read_spectra_csv(&empty), Err(Error::Empty { origin }) if origin == empty.display().to_string()));
}

#[test]
fn comment_and_blank_lines_are_skipped_but_counted() {
    // A file whose first lines are `#` comments used to be rejected. Comments may come
    // before the header and between rows (indented too), with CRLF line ends.
    let text = "# Measured 2026-12-01, 1 nm\r\n#\r\n\r\nwavelength_nm,a\r\n  # a comment between rows\r\n400,0.25\r\n\r\n410,0.75\r\n";
    let path = write("commented.csv", text);
    let table = read_spectra_csv(&path).unwrap();
    assert_eq!(table.len(), 1);
    assert_eq!(table[0].name, "a");
    assert_eq!(table[0].spectrum.step(), 10.0);
    assert_eq!(table[0].spectrum.eval(405.0), 0.5);
    // Errors still name the file's own line (line 7: two comments, a blank, the header, …).
    let bad = write("commented_bad.csv", "# c\n#\n\nwavelength_nm,a\n# c\n400,1\nx,1\n");
    let err = read_spectra_csv(&bad).unwrap_err();
    assert_eq!(err.to_string(), format!("{}:7: column `wavelength_nm`: `x` is not a number", bad.display()));
    // A file of comments only has no data.
    let only = write("comments_only.csv", "# nothing\n# here\n");
    assert!(matches!(read_spectra_csv(&only), Err(Error::Empty { .. })));
}

/// What each committed CSV regression input (`fuzz/regressions/csv/`) must give.
enum Expected {
    /// `read_spectra_csv` fails with the file's path followed by this.
    Parse(&'static str),
    /// The file parses; extending its first column to 360–830 nm fails with this.
    Held(&'static str),
}

/// Before their fixes, each of these panicked (`capacity overflow`), aborted allocating
/// terabytes, overflowed an integer, printed `null` or was held flat across the visible range
/// unannounced; now each is a one-line error with the file and line.
const REGRESSIONS: [(&str, Expected); 5] = [
    (
        "close_rows.csv",
        Expected::Parse(
            ":3: wavelength 500.0000000001 nm is only 9.99875737761613e-11 nm after 500 nm (rows must be at least 0.001 nm apart)",
        ),
    ),
    ("far_wavelength.csv", Expected::Parse(":4: wavelength 1e300 nm is beyond the longest supported, 100000 nm")),
    (
        "tiny_wavelengths.csv",
        Expected::Parse(
            ":3: wavelength 2e-300 nm is only 1e-300 nm after 1e-300 nm (rows must be at least 0.001 nm apart)",
        ),
    ),
    (
        "ultraviolet_only.csv",
        Expected::Held("spectrum defined only at 100–300 nm, outside the visible range 360–830 nm"),
    ),
    ("value_1e308.csv", Expected::Parse(":2: column `a`: 1e308 is too large (spectra must be <= 1e30)")),
];

#[test]
fn every_csv_fuzz_regression_is_the_error_it_should_be() {
    let folder = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../fuzz/regressions/csv");
    let mut names: Vec<String> = std::fs::read_dir(&folder)
        .unwrap_or_else(|e| panic!("{}: {e}", folder.display()))
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| !n.starts_with('.'))
        .collect();
    names.sort();
    // A new regression input needs its expected message here.
    assert_eq!(names, REGRESSIONS.map(|(name, _)| name), "{}", folder.display());
    for (name, expected) in REGRESSIONS {
        let path = folder.join(name);
        match expected {
            Expected::Parse(message) => {
                let err = read_spectra_csv(&path).unwrap_err();
                assert_eq!(err.to_string(), format!("{}{message}", path.display()), "{name}");
            }
            Expected::Held(message) => {
                let table = read_spectra_csv(&path).unwrap();
                assert_eq!(table[0].spectrum.held_to_visible().unwrap_err().to_string(), message, "{name}");
            }
        }
    }
}

#[test]
fn hostile_grids_are_errors_naming_the_file_and_line_not_allocations() {
    // The committed regression inputs are checked above; a megabyte-long cell is quoted short.
    let long_cell = write("long_cell.csv", &format!("wavelength_nm,a\n400,{}\n", "x".repeat(100_000)));
    let err = read_spectra_csv(&long_cell).unwrap_err();
    assert_eq!(
        err.to_string(),
        format!("{}:2: column `a`: `xxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxx…` is not a number", long_cell.display())
    );
    // A header of 5000 columns is refused from its count, before a column is allocated.
    let wide = write("wide_header.csv", &format!("wavelength_nm{}\n400{}\n", ",a".repeat(4999), ",1".repeat(4999)));
    let err = read_spectra_csv(&wide).unwrap_err();
    assert_eq!(err.to_string(), format!("{}:1: 5000 columns, more than the limit of 4096", wide.display()));
    // Uneven rows from 1 to 100 000 nm in 200 columns would resample to 2e7 values
    // (160 MB): refused as a whole before any column is built.
    let header: String = (0..200).map(|i| format!(",c{i}")).collect();
    let row = |l: &str| format!("{l}{}\n", ",0.5".repeat(200));
    let uneven = write("uneven_wide.csv", &format!("wavelength_nm{header}\n{}{}{}", row("1"), row("3"), row("100000")));
    let err = read_spectra_csv(&uneven).unwrap_err();
    assert!(matches!(err, Error::TooManySamples { .. }), "{err}");
    assert!(err.to_string().starts_with(&format!("{}:", uneven.display())), "{err}");
}

#[test]
fn only_regular_files_of_bounded_size_are_read() {
    // A device would be read forever (`/dev/zero`); a FIFO would block on open.
    #[cfg(unix)]
    {
        let err = read_spectra_csv(std::path::Path::new("/dev/zero")).unwrap_err();
        assert_eq!(err.to_string(), "/dev/zero: not a regular file");
    }
    let folder = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("colorimetry-csv");
    std::fs::create_dir_all(&folder).unwrap();
    assert!(matches!(read_spectra_csv(&folder), Err(Error::NotReadable { .. })));
    // A sparse file one byte over the limit: refused from its size, without reading it.
    let big = folder.join("too_big.csv");
    std::fs::File::create(&big).unwrap().set_len(colorimetry::MAX_CSV_BYTES + 1).unwrap();
    let err = read_spectra_csv(&big).unwrap_err();
    assert_eq!(
        err.to_string(),
        format!("{}: 67108865 bytes, more than the limit for a spectra file (67108864 bytes)", big.display())
    );
    std::fs::remove_file(&big).unwrap();
}

#[test]
fn a_spectrum_overlapping_the_visible_range_is_held_across_it() {
    // 100–300 nm used to be held flat over 360–830 nm, silently (now an error, see
    // `ultraviolet_only.csv` in the regressions above). One that overlaps the range is
    // extended as before.
    let path = write("partly_visible.csv", "wavelength_nm,a\n300,0.5\n400,0.25\n");
    let held = read_spectra_csv(&path).unwrap()[0].spectrum.held_to_visible().unwrap();
    // Linear from 0.5 at 300 nm to 0.25 at 400 nm: 0.35 at 360 nm, to one rounding.
    assert!((held.eval(360.0) - 0.35).abs() < 1e-15, "{}", held.eval(360.0));
    assert_eq!((held.eval(400.0), held.eval(830.0)), (0.25, 0.25));
}
