//! Degenerate volumes (1x1x1, 1xNxN, Nx1x1, 2x2x2): every scene, sliced
//! and bricked, through every tool and format and back.

use super::*;

/// A volume through every tool: gen, info, index, convert to each format
/// and back, and psnr of the copies against the original (identical).
fn through_every_tool(dims: &str, layouts: &[&str]) {
    let d = tmp();
    for scene in ["shapes", "spheres", "noise", "solid", "ramp", "sphere"] {
        for layout in layouts {
            let name = format!("{scene}-{}.vvol", layout.replace(':', ""));
            let v = gen(
                d.path(),
                &name,
                &[scene, "--dims", dims, "--layout", layout, "--size", "1"],
            );
            let j = json(&ok(bin("vol-info").arg(&v).args(["--json", "--verify"])));
            assert_eq!(j["dims"].to_string().replace(' ', ""), format!("[{dims}]"));
            ok(bin("vol-index").arg(&v).arg("-q"));
            ok(bin("vol-index")
                .arg("--check")
                .arg(d.path().join(format!("{name}.vidx")))
                .arg(&v)
                .arg("-q"));
            for ext in ["vol", "raw", "tif", "vvol"] {
                let dims_u: Vec<&str> = dims.split(',').collect();
                let out = d.path().join(format!(
                    "copy_{}x{}x{}_u8.{ext}",
                    dims_u[0], dims_u[1], dims_u[2]
                ));
                ok(bin("vol-convert").arg(&v).arg("-q").arg("-o").arg(&out));
                let back = d.path().join("back.vvol");
                ok(bin("vol-convert").arg(&out).arg("-q").arg("-o").arg(&back));
                let s = ok(bin("vol-psnr").arg(&v).arg(&back));
                assert!(s.contains("identical"), "{name} via {ext}: {s}");
            }
        }
    }
}

#[test]
fn degenerate_1x1x1_through_every_tool() {
    through_every_tool("1,1,1", &["sliced", "bricked:2"]);
}

#[test]
fn degenerate_1xnxn_through_every_tool() {
    through_every_tool("1,5,5", &["sliced", "bricked:2"]);
}

#[test]
fn degenerate_nx1x1_through_every_tool() {
    through_every_tool("7,1,1", &["sliced", "bricked:4"]);
}

#[test]
fn degenerate_2x2x2_through_every_tool() {
    through_every_tool("2,2,2", &["sliced", "bricked:2"]);
}
