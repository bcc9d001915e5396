#!/usr/bin/env python3
"""Write the small test fixtures under tests/fixtures/ with the reference
tools of each format, so volkit is tested against files it did not write:

- nibabel_int16.nii.gz: NIfTI-1 by nibabel, int16 with scl_slope 2 and
  scl_inter -10, an affine with a flipped axis and an origin.
- nibabel_f64.nii: NIfTI-2 by nibabel, float64.
- dicom_ct/: a CT series by pydicom, 10 slices of 16x12 uint16 with
  RescaleIntercept -1024, files named and numbered in shuffled order.
- dicom_mr/: a second series (3 slices of 8x8, int16), for directories
  holding several series.
- dicom_tilt/: 3 slices whose positions do not follow the slice normal
  (gantry tilt).
- dicom_pacs/: a folder as a PACS exports it: two image series (CT
  #3 "Axial 2.0", 4 slices of 6x5 uint16; MR #7 "Axial T1", 3 slices of
  5x4 int16; UIDs ...498.40 and ...498.41 share the prefix ...498.4), a
  Basic Text SR, a grayscale softcopy presentation state and a DICOMDIR
  (written by pydicom's FileSet; its records point into the FileSet's own
  layout, which is not kept).
- tifffile_ome.ome.tif: OME-TIFF by tifffile, axes ZCYX (5 x 2 x 8 x 6,
  uint16), PhysicalSizeX/Y 0.25, PhysicalSizeZ 1.5.
- tifffile_hyperstack.tif: ImageJ hyperstack by tifffile, axes TZCYX
  (2 x 4 x 2 x 6 x 5, uint8).
- tifffile_zstd_i32.tif: int32 pages, zstd-compressed (needs imagecodecs).

Values follow formulas the Rust tests repeat (tests/it/formats.rs):
  NIfTI: stored = i + 10 j + 100 k, real = 2 stored - 10
  CT: stored = 10 (x + 2 y + 3 k) at the k-th slice from the lowest z,
      HU = stored - 1024
  TIFF: value = x + 10 y + 100 z + 1000 c + 5000 t (uint8 ones: modulo 256;
      int32: minus 70000)

Run: pip install nibabel pydicom tifffile imagecodecs && python3 scripts/make-fixtures.py
"""
import os
import random
import shutil

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "..", "tests", "fixtures")


def nifti():
    import nibabel as nib

    i, j, k = np.meshgrid(np.arange(8), np.arange(7), np.arange(6), indexing="ij")
    stored = (i + 10 * j + 100 * k).astype(np.int16)
    affine = np.array(
        [[-0.5, 0, 0, 10.0], [0, 0.75, 0, -20.0], [0, 0, 1.5, 30.0], [0, 0, 0, 1]]
    )
    img = nib.Nifti1Image(stored, affine)
    img.header.set_data_dtype(np.int16)
    img.header["scl_slope"] = 2.0
    img.header["scl_inter"] = -10.0
    img.set_qform(affine, code=1)
    img.set_sform(affine, code=2)
    nib.save(img, os.path.join(OUT, "nibabel_int16.nii.gz"))

    f = (i * 0.25 + j - k * 1.5).astype(np.float64)
    img2 = nib.Nifti2Image(f, np.diag([2.0, 2.0, 3.0, 1.0]))
    nib.save(img2, os.path.join(OUT, "nibabel_f64.nii"))


def dicom_series(name, series_uid, nx, ny, nz, spacing_z, rescale, dtype, tilt=0.0, seed=1,
                 clear=True, prefix="IM", number=None, description=None, modality="CT"):
    import pydicom
    from pydicom.dataset import Dataset, FileMetaDataset
    from pydicom.uid import CTImageStorage, ExplicitVRLittleEndian

    d = os.path.join(OUT, name)
    if clear:
        shutil.rmtree(d, ignore_errors=True)
    os.makedirs(d, exist_ok=True)
    written = []
    order = list(range(nz))
    random.Random(seed).shuffle(order)
    study = "1.2.826.0.1.3680043.8.498.1"
    for n, k in enumerate(order):
        meta = FileMetaDataset()
        meta.MediaStorageSOPClassUID = CTImageStorage
        meta.MediaStorageSOPInstanceUID = f"{series_uid}.{k + 1}"
        meta.TransferSyntaxUID = ExplicitVRLittleEndian
        ds = Dataset()
        ds.file_meta = meta
        ds.SOPClassUID = CTImageStorage
        ds.SOPInstanceUID = meta.MediaStorageSOPInstanceUID
        ds.StudyInstanceUID = study
        ds.SeriesInstanceUID = series_uid
        ds.Modality = modality
        if number is not None:
            ds.SeriesNumber = number
        if description is not None:
            ds.SeriesDescription = description
        ds.PatientName = "Fixture^Synthetic"
        ds.PatientID = "0"
        # Shuffled: neither file names nor instance numbers follow z.
        ds.InstanceNumber = order[(n + 3) % nz] + 1
        ds.ImagePositionPatient = [-40.0 + tilt * k, -30.0, 12.5 + spacing_z * k]
        ds.ImageOrientationPatient = [1, 0, 0, 0, 1, 0]
        ds.PixelSpacing = [0.8, 0.7]  # row spacing (y), column spacing (x)
        ds.SliceThickness = spacing_z
        ds.Rows = ny
        ds.Columns = nx
        ds.SamplesPerPixel = 1
        ds.PhotometricInterpretation = "MONOCHROME2"
        ds.BitsAllocated = 16
        ds.BitsStored = 16
        ds.HighBit = 15
        ds.PixelRepresentation = 1 if dtype == np.int16 else 0
        ds.RescaleSlope = rescale[0]
        ds.RescaleIntercept = rescale[1]
        x, y = np.meshgrid(np.arange(nx), np.arange(ny), indexing="xy")
        px = (10 * (x + 2 * y + 3 * k)).astype(dtype)
        ds.PixelData = px.tobytes()
        ds.save_as(os.path.join(d, f"{prefix}{n * 7919 % 1000:04d}.dcm"), enforce_file_format=True)
        written.append(ds)
    return written


def dicom_pacs():
    """Two series, an SR, a presentation state and a DICOMDIR in one folder."""
    import tempfile

    from pydicom.dataset import Dataset, FileMetaDataset
    from pydicom.fileset import FileSet
    from pydicom.uid import (
        BasicTextSRStorage,
        ExplicitVRLittleEndian,
        GrayscaleSoftcopyPresentationStateStorage,
    )

    name = "dicom_pacs"
    base = "1.2.826.0.1.3680043.8.498.4"
    images = dicom_series(name, base + "0", 6, 5, 4, 2.0, (1, -1024), np.uint16, seed=3,
                          prefix="CT", number=3, description="Axial 2.0")
    images += dicom_series(name, base + "1", 5, 4, 3, 1.5, (1, 0), np.int16, seed=4,
                           clear=False, prefix="MR", number=7, description="Axial T1", modality="MR")
    others = []
    for uid, cls, modality, number in [
        (base + "2", BasicTextSRStorage, "SR", 99),
        (base + "3", GrayscaleSoftcopyPresentationStateStorage, "PR", 98),
    ]:
        meta = FileMetaDataset()
        meta.MediaStorageSOPClassUID = cls
        meta.MediaStorageSOPInstanceUID = uid + ".1"
        meta.TransferSyntaxUID = ExplicitVRLittleEndian
        ds = Dataset()
        ds.file_meta = meta
        ds.SOPClassUID = cls
        ds.SOPInstanceUID = meta.MediaStorageSOPInstanceUID
        ds.StudyInstanceUID = images[0].StudyInstanceUID
        ds.SeriesInstanceUID = uid
        ds.SeriesNumber = number
        ds.InstanceNumber = 1
        ds.Modality = modality
        ds.PatientName = "Fixture^Synthetic"
        ds.PatientID = "0"
        ds.ContentDate = "20260101"
        ds.ContentTime = "120000"
        if modality == "SR":
            ds.ValueType = "CONTAINER"
            ds.ContinuityOfContent = "SEPARATE"
            ds.CompletionFlag = "COMPLETE"
            ds.VerificationFlag = "UNVERIFIED"
            code = Dataset()
            code.CodeValue = "18748-4"
            code.CodingSchemeDesignator = "LN"
            code.CodeMeaning = "Diagnostic Imaging Report"
            ds.ConceptNameCodeSequence = [code]
        else:
            ds.ContentLabel = "FIXTURE"
            ds.PresentationCreationDate = "20260101"
            ds.PresentationCreationTime = "120000"
            ds.InstanceCreationDate = "20260101"
        ds.save_as(os.path.join(OUT, name, f"{modality}000001.dcm"), enforce_file_format=True)
        others.append(ds)
    fs = FileSet()
    for ds in images + others:
        # What the DICOMDIR's study record needs (the records only).
        ds.StudyDate, ds.StudyTime, ds.StudyID = "20260101", "120000", "1"
        fs.add(ds)
    with tempfile.TemporaryDirectory() as tmp:
        fs.write(tmp)
        shutil.copy(os.path.join(tmp, "DICOMDIR"), os.path.join(OUT, name, "DICOMDIR"))


def tiffs():
    import tifffile

    def volume(t, z, c, y, x):
        tt, zz, cc, yy, xx = np.meshgrid(
            np.arange(t), np.arange(z), np.arange(c), np.arange(y), np.arange(x), indexing="ij"
        )
        return xx + 10 * yy + 100 * zz + 1000 * cc + 5000 * tt

    ome = volume(1, 5, 2, 8, 6)[0].astype(np.uint16)
    tifffile.imwrite(
        os.path.join(OUT, "tifffile_ome.ome.tif"),
        ome,
        ome=True,
        metadata={"axes": "ZCYX", "PhysicalSizeX": 0.25, "PhysicalSizeY": 0.25, "PhysicalSizeZ": 1.5},
    )
    hyper = (volume(2, 4, 2, 6, 5) % 256).astype(np.uint8)
    tifffile.imwrite(
        os.path.join(OUT, "tifffile_hyperstack.tif"),
        hyper,
        imagej=True,
        metadata={"axes": "TZCYX", "spacing": 2.0},
    )
    wide = (volume(1, 3, 1, 6, 5)[0, :, 0] - 70000).astype(np.int32)
    tifffile.imwrite(
        os.path.join(OUT, "tifffile_zstd_i32.tif"), wide, compression="zstd", photometric="minisblack"
    )


def main():
    os.makedirs(OUT, exist_ok=True)
    nifti()
    tiffs()
    dicom_series("dicom_ct", "1.2.826.0.1.3680043.8.498.10", 16, 12, 10, 2.5, (1, -1024), np.uint16)
    dicom_series("dicom_mr", "1.2.826.0.1.3680043.8.498.20", 8, 8, 3, 1.0, (1, 0), np.int16, seed=2)
    dicom_series("dicom_tilt", "1.2.826.0.1.3680043.8.498.30", 4, 4, 3, 2.0, (1, 0), np.int16, tilt=0.5)
    dicom_pacs()


if __name__ == "__main__":
    main()
