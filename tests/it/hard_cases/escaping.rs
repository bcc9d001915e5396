//! Control bytes and long excerpts in messages: text from a crafted
//! header, a file name or an argument reaches stderr escaped and cut.

use super::*;

/// Bug: NRRD header lines went raw into errors, terminal escapes too (fixed in 4543c7c).
#[test]
fn nrrd_control_bytes_in_a_header_line_are_escaped() {
    let d = tmp();
    let p = nrrd(
        d.path(),
        "esc.nrrd",
        "NRRD0004\ntype: uchar\n\x1b[2J\x1b]0;pwned\x07\0oops\nsizes: 2 2 2\n\n",
        &[0u8; 8],
    );
    let out = run(bin("vol-convert")
        .arg(&p)
        .arg("-o")
        .arg(d.path().join("o.vvol")));
    assert_eq!(code(&out), 1);
    no_control_bytes(&out.stderr);
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("\\x1b[2J"), "{err}");
    assert_eq!(err.lines().count(), 1);
}

/// Bug: NRRD header lines went raw into errors, kilobytes of binary too (fixed in 4543c7c).
#[test]
fn nrrd_binary_header_excerpt_is_cut_short() {
    let d = tmp();
    let junk: Vec<u8> = (0..20_000u32)
        .map(|i| (i * 7919 % 251) as u8)
        .filter(|&b| b != b'\n')
        .collect();
    let mut header = b"NRRD0004\ntype: uchar\n".to_vec();
    header.extend_from_slice(&junk);
    header.extend_from_slice(b"\n\n");
    let p = d.path().join("bin.nrrd");
    std::fs::write(&p, &header).unwrap();
    let out = run(bin("vol-convert")
        .arg(&p)
        .arg("-o")
        .arg(d.path().join("o.vvol")));
    assert_eq!(code(&out), 1);
    no_control_bytes(&out.stderr);
    assert!(
        out.stderr.len() < 600,
        "{} bytes of message",
        out.stderr.len()
    );
}

/// Bug: bad NRRD header values were quoted raw, terminal escapes too (fixed in 4543c7c).
#[test]
fn nrrd_bad_values_are_named_and_escaped() {
    let d = tmp();
    for (field, needle) in [
        ("type: \x1b[31mdouble\n", "\\x1b[31mdouble"),
        ("sizes: 2 x\x00 2\n", "sizes"),
        ("encoding: \u{9b}bzip2\n", "\\x9bbzip2"),
    ] {
        let p = nrrd(
            d.path(),
            "v.nrrd",
            &format!("NRRD0004\n{field}type: uchar\nsizes: 2 2 2\nencoding: raw\n\n"),
            &[0u8; 8],
        );
        let out = run(bin("vol-convert")
            .arg(&p)
            .arg("-o")
            .arg(d.path().join("o.vvol")));
        assert_eq!(code(&out), 1);
        no_control_bytes(&out.stderr);
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(needle), "{err}");
    }
}

/// Bug: a crafted MetaImage header sent terminal escapes through an error (fixed in ce689a4).
#[test]
fn mhd_control_bytes_are_escaped() {
    let d = tmp();
    let p = d.path().join("e.mha");
    std::fs::write(
        &p,
        b"NDims = 3\nDimSize = 2 2 2\nElementType = MET_\x1b[5mLONG\nElementDataFile = LOCAL\n\0\0",
    )
    .unwrap();
    let out = run(bin("vol-convert")
        .arg(&p)
        .arg("-o")
        .arg(d.path().join("o.vvol")));
    assert_eq!(code(&out), 1);
    no_control_bytes(&out.stderr);
    assert!(String::from_utf8_lossy(&out.stderr).contains("MET_\\x1b[5mLONG"));
}

/// Bug: a crafted PFM header sent escapes and kilobytes of text into an error (fixed in ce689a4).
#[test]
fn pfm_header_tokens_are_escaped_and_cut() {
    let d = tmp();
    let p = d.path().join("e.pfm");
    let mut b = b"Pf\n\x1b[31m".to_vec();
    b.extend(std::iter::repeat_n(b'9', 5000));
    b.extend_from_slice(b" 1\n-1\n\0\0\0\0");
    std::fs::write(&p, &b).unwrap();
    let out = run(bin("vol-psnr").arg(&p).arg(&p));
    assert_eq!(code(&out), 1);
    no_control_bytes(&out.stderr);
    assert!(
        out.stderr.len() < 400,
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn control_bytes_in_a_file_name_are_escaped() {
    let d = tmp();
    let p = d.path().join("evil\x1b[31m\x07name.vvol");
    std::fs::write(&p, b"not a volume").unwrap();
    for t in ["vol-info", "vol-index"] {
        let out = run(bin(t).arg(&p));
        assert_eq!(code(&out), 1);
        no_control_bytes(&out.stderr);
        assert!(String::from_utf8_lossy(&out.stderr).contains("evil\\x1b[31m\\x07name"));
    }
    let out = run(bin("vol-psnr").arg(&p).arg(&p));
    no_control_bytes(&out.stderr);
    let out = run(bin("vol-convert")
        .arg(&p)
        .arg("-o")
        .arg(d.path().join("o.vvol")));
    no_control_bytes(&out.stderr);
}

#[test]
fn control_bytes_in_arguments_are_escaped() {
    let out = run(bin("vol-info").args(["x.raw", "--raw-type", "\x1b]0;title\x07"]));
    assert_eq!(code(&out), 2);
    no_control_bytes(&out.stderr);
    let out = run(bin("vol-gen").args(["solid", "--dims", "\x1b[2J", "-o", "x.vvol"]));
    assert_eq!(code(&out), 2);
    no_control_bytes(&out.stderr);
}
