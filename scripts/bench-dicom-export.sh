#!/usr/bin/env bash
# Benchmark: a whole DICOM export (issue 64's targets). Input: SERIES
# series of SLICES 128x128 i16 slices each (default 10 x 700: 7,000
# files), written by pydicom with the files of all series shuffled in one
# folder. In turn (A B A B ...; farm-bench's pairing), RUNS times:
#   all:  vol-convert EXPORT --series all -o 'OUT/{number}.nii'
#     vs  dcm2niix -z n -f %s -o OUT2 EXPORT      target: ratio <= 1
#   one:  vol-convert EXPORT --series 3 -o one.nii
#     vs  dcm2niix on the whole folder, as above  target: ratio <= 0.5
# Both write uncompressed NIfTI, on every core they use (dcm2niix is
# single-threaded). The files are in the page cache (a warm-up run
# each). The medians of the pairs' ratios, with the load, are the figures.
# Peers: python3 with pydicom and numpy; dcm2niix (Debian dcm2niix).
# Usage: scripts/bench-dicom-export.sh [RUNS]   (default 5)
#        DIR=out/bench-dicom-export, BUILD=0 (no cargo), SERIES=10, SLICES=700.
set -euo pipefail
cd "$(dirname "$0")/.."
RUNS=${1:-5}
DIR=${DIR:-out/bench-dicom-export}
SERIES=${SERIES:-10}
SLICES=${SLICES:-700}
mkdir -p "$DIR"
if [ "${BUILD:-1}" = 1 ]; then
    cargo build --release --quiet --bin vol-convert
fi
B=${CARGO_TARGET_DIR:-target}/release
command -v dcm2niix >/dev/null || { echo "bench-dicom-export: needs dcm2niix (apt-get install dcm2niix)" >&2; exit 1; }
command -v farm-bench >/dev/null || { echo "bench-dicom-export: needs farm-bench on PATH" >&2; exit 1; }
python3 -c 'import pydicom, numpy' 2>/dev/null ||
    { echo "bench-dicom-export: needs python3 with pydicom and numpy" >&2; exit 1; }

export_dir=$DIR/export
stamp=$export_dir/.done-$SERIES-$SLICES
if [ ! -f "$stamp" ]; then
    echo "bench-dicom-export: writing $SERIES series of $SLICES slices (pydicom)" >&2
    rm -rf "$export_dir"
    mkdir -p "$export_dir"
    python3 - "$export_dir" "$SERIES" "$SLICES" <<'EOF'
import random, sys, numpy as np
from pydicom.dataset import Dataset, FileMetaDataset
from pydicom.uid import ExplicitVRLittleEndian, generate_uid
out, n_series, n_slices = sys.argv[1], int(sys.argv[2]), int(sys.argv[3])
rng = np.random.default_rng(7)
study = generate_uid()
names = list(range(n_series * n_slices))
random.Random(7).shuffle(names)
k = 0
y, x = np.mgrid[0:128, 0:128]
for s in range(n_series):
    series = generate_uid()
    for z in range(n_slices):
        m = FileMetaDataset()
        m.MediaStorageSOPClassUID = "1.2.840.10008.5.1.4.1.1.2"
        m.MediaStorageSOPInstanceUID = generate_uid()
        m.TransferSyntaxUID = ExplicitVRLittleEndian
        ds = Dataset(); ds.file_meta = m
        ds.SOPClassUID = m.MediaStorageSOPClassUID; ds.SOPInstanceUID = m.MediaStorageSOPInstanceUID
        ds.Modality = "CT"; ds.StudyInstanceUID = study; ds.SeriesInstanceUID = series
        ds.SeriesNumber = s + 1; ds.InstanceNumber = z + 1
        ds.SeriesDescription = f"series {s + 1}"
        ds.ImagePositionPatient = [-64.0, -64.0, float(z)]; ds.ImageOrientationPatient = [1, 0, 0, 0, 1, 0]
        ds.PixelSpacing = [1, 1]; ds.SliceThickness = 1
        ds.Rows = ds.Columns = 128
        ds.SamplesPerPixel = 1; ds.PhotometricInterpretation = "MONOCHROME2"
        ds.BitsAllocated = 16; ds.BitsStored = 16; ds.HighBit = 15; ds.PixelRepresentation = 1
        ds.RescaleIntercept = 0; ds.RescaleSlope = 1
        img = ((x - 64) ** 2 + (y - 64) ** 2 < (40 + s) ** 2) * (1000 + z) - 1000
        ds.PixelData = img.astype("<i2").tobytes()
        ds.save_as(f"{out}/IM{names[k]:06d}.dcm", enforce_file_format=True)
        k += 1
EOF
    touch "$stamp"
fi
echo "bench-dicom-export: $(find "$export_dir" -name '*.dcm' | wc -l) files, $(du -sh "$export_dir" | cut -f1)" >&2
mkdir -p "$DIR/ours" "$DIR/theirs"
peer="sh -c 'rm -rf $DIR/theirs && mkdir $DIR/theirs && exec dcm2niix -z n -f %s -o $DIR/theirs $export_dir >/dev/null'"
echo "== load before: $(cut -d' ' -f1-3 /proc/loadavg)"
echo "== all series: vol-convert --series all / dcm2niix"
farm-bench -n "$RUNS" --timeout 3000 --vs "$peer" -- \
    "$B/vol-convert" "$export_dir" --series all -o "$DIR/ours/{number}.nii" -q | tee "$DIR/report-all.txt"
echo "== one series: vol-convert --series 3 / dcm2niix on the whole folder"
farm-bench -n "$RUNS" --timeout 3000 --vs "$peer" -- \
    "$B/vol-convert" "$export_dir" --series 3 -o "$DIR/one.nii" -q | tee "$DIR/report-one.txt"
echo "== load after: $(cut -d' ' -f1-3 /proc/loadavg)"
# The same volumes: series 3 of both, voxel for voxel in world space.
python3 - "$DIR/ours/3.nii" "$DIR/theirs" <<'EOF' || true
import glob, sys
try:
    import nibabel as nib, numpy as np
except ImportError:
    sys.exit(0)
ours = nib.as_closest_canonical(nib.load(sys.argv[1]))
theirs = [nib.as_closest_canonical(nib.load(f)) for f in glob.glob(sys.argv[2] + "/3*.nii")]
same = any(t.shape == ours.shape and np.allclose(t.affine, ours.affine, atol=1e-3)
           and (t.get_fdata() == ours.get_fdata()).all() for t in theirs)
print("== series 3:", "equal to dcm2niix's" if same else "DIFFERS from dcm2niix's")
EOF
