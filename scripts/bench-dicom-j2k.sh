#!/usr/bin/env bash
# Benchmark: decoding a JPEG 2000 lossless CT series (issue 64's target:
# at least as fast as GDCM through SimpleITK). Input: a 512x512x300 i16
# CT-like head (vol-gen phantom, 0.5x0.5x1 mm), written as 300 DICOM
# slices by pydicom, each compressed by gdcmconv --j2k (lossless). Then,
# in turn (A B A B ...; farm-bench's pairing), RUNS times:
#   A: vol-convert SERIES -o out.raw           (pure-Rust openjp2, rayon)
#   B: SimpleITK ImageSeriesReader (GDCM, OpenJPEG in C) + WriteImage .mha
# Both read every file, decode every frame, and write the volume
# uncompressed; B's Python start-up and import are in its time (about
# 0.3 s here, which disfavours it: the report gives its import alone
# too). Both get every core. The ratio A/B, median of the pairs, with the
# load average, is the figure; below 1 means volkit is faster.
# Peers: python3 with SimpleITK, pydicom, nibabel and numpy; gdcmconv
# (Debian libgdcm-tools). A missing peer stops the script naming it.
# Usage: scripts/bench-dicom-j2k.sh [RUNS]   (default 5)
#        DIR=out/bench-dicom-j2k, BUILD=0 (no cargo), DIMS=512,512,300.
set -euo pipefail
cd "$(dirname "$0")/.."
RUNS=${1:-5}
DIR=${DIR:-out/bench-dicom-j2k}
DIMS=${DIMS:-512,512,300}
mkdir -p "$DIR"
if [ "${BUILD:-1}" = 1 ]; then
    cargo build --release --quiet --bin vol-gen --bin vol-convert
fi
B=${CARGO_TARGET_DIR:-target}/release
command -v gdcmconv >/dev/null || { echo "bench-dicom-j2k: needs gdcmconv (apt-get install libgdcm-tools)" >&2; exit 1; }
command -v farm-bench >/dev/null || { echo "bench-dicom-j2k: needs farm-bench on PATH" >&2; exit 1; }
python3 -c 'import SimpleITK, pydicom, nibabel, numpy' 2>/dev/null ||
    { echo "bench-dicom-j2k: needs python3 with SimpleITK, pydicom, nibabel, numpy" >&2; exit 1; }

series=$DIR/j2k
if [ ! -f "$series/.done-$DIMS" ]; then
    echo "bench-dicom-j2k: writing the $DIMS series (pydicom, then gdcmconv --j2k)" >&2
    rm -rf "$DIR/plain" "$series"
    mkdir -p "$DIR/plain" "$series"
    "$B/vol-gen" phantom --dims "$DIMS" --spacing 0.5,0.5,1 -o "$DIR/ct.vvol" -q
    "$B/vol-convert" "$DIR/ct.vvol" -o "$DIR/ct.nii" -q
    python3 - "$DIR/ct.nii" "$DIR/plain" <<'EOF'
import sys, numpy as np, nibabel as nib, pydicom
from pydicom.dataset import Dataset, FileMetaDataset
from pydicom.uid import ExplicitVRLittleEndian, generate_uid
src, out = sys.argv[1], sys.argv[2]
vol = np.asanyarray(nib.load(src).dataobj)  # x, y, z
series, study = generate_uid(), generate_uid()
for z in range(vol.shape[2]):
    m = FileMetaDataset()
    m.MediaStorageSOPClassUID = "1.2.840.10008.5.1.4.1.1.2"
    m.MediaStorageSOPInstanceUID = generate_uid()
    m.TransferSyntaxUID = ExplicitVRLittleEndian
    ds = Dataset(); ds.file_meta = m
    ds.SOPClassUID = m.MediaStorageSOPClassUID; ds.SOPInstanceUID = m.MediaStorageSOPInstanceUID
    ds.Modality = "CT"; ds.StudyInstanceUID = study; ds.SeriesInstanceUID = series
    ds.SeriesNumber = 1; ds.InstanceNumber = z + 1
    ds.ImagePositionPatient = [0, 0, float(z)]; ds.ImageOrientationPatient = [1, 0, 0, 0, 1, 0]
    ds.PixelSpacing = [0.5, 0.5]; ds.SliceThickness = 1
    ds.Rows, ds.Columns = vol.shape[1], vol.shape[0]
    ds.SamplesPerPixel = 1; ds.PhotometricInterpretation = "MONOCHROME2"
    ds.BitsAllocated = 16; ds.BitsStored = 16; ds.HighBit = 15; ds.PixelRepresentation = 1
    ds.RescaleIntercept = 0; ds.RescaleSlope = 1
    ds.PixelData = np.ascontiguousarray(vol[:, :, z].T).astype("<i2").tobytes()
    ds.save_as(f"{out}/{z:04d}.dcm", enforce_file_format=True)
EOF
    for f in "$DIR"/plain/*.dcm; do
        gdcmconv --j2k "$f" "$series/$(basename "$f")"
    done
    touch "$series/.done-$DIMS"
fi
echo "bench-dicom-j2k: $(ls "$series" | wc -l) files, $(du -sh "$series" | cut -f1) (uncompressed $(du -sh "$DIR/plain" | cut -f1))" >&2

# The two decode to the same values: checked once, before timing.
"$B/vol-convert" "$series" -o "$DIR/a.raw" -q
python3 - "$series" "$DIR/a.raw" "$DIMS" <<'EOF'
import sys, numpy as np, SimpleITK as sitk
r = sitk.ImageSeriesReader(); r.SetFileNames(r.GetGDCMSeriesFileNames(sys.argv[1]))
b = sitk.GetArrayFromImage(r.Execute())  # z, y, x
x, y, z = map(int, sys.argv[3].split(","))
a = np.fromfile(sys.argv[2], dtype="<i2").reshape(z, y, x)
assert a.shape == b.shape and (a == b).all(), "volkit and SimpleITK decode differently"
print("bench-dicom-j2k: volkit and SimpleITK decode the same values", file=sys.stderr)
EOF
cat > "$DIR/sitk.py" <<'EOF'
import sys, time
t0 = time.perf_counter()
import SimpleITK as sitk
t1 = time.perf_counter()
r = sitk.ImageSeriesReader(); r.SetFileNames(r.GetGDCMSeriesFileNames(sys.argv[1]))
sitk.WriteImage(r.Execute(), sys.argv[2])
print(f"import {t1 - t0:.3f} s, read and write {time.perf_counter() - t1:.3f} s")
EOF
echo "== load before: $(cut -d' ' -f1-3 /proc/loadavg)"
farm-bench -n "$RUNS" --timeout 3000 \
    --vs "python3 $DIR/sitk.py $series $DIR/b.mha" \
    -- "$B/vol-convert" "$series" -o "$DIR/a.raw" -q | tee "$DIR/report.txt"
echo "== SimpleITK's own split: $(python3 "$DIR/sitk.py" "$series" "$DIR/b.mha")"
echo "== load after: $(cut -d' ' -f1-3 /proc/loadavg)"
