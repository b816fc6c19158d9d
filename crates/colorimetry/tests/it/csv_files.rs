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
