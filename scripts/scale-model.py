#!/usr/bin/env python3
"""Frame-time and conversion-time model for volkit at scale (docs/SCALE.md).

From figures measured on one machine (the defaults; see docs/SCALE.md for
where each comes from) and stated assumptions about the cluster, prints
two Markdown tables:

  1. a data-parallel frame (vol-render under MPI) of a 10,000^3 volume at
     3840x2160 on 16 to 1024 ranks, compositing by binary swap (log2 N
     rounds) then a gather to rank 0;
  2. a sharded conversion (vol-convert --shard) of 10,000 slices of
     10,000 x 10,000 u16, with the merge into one .vvol or, without a
     merge, OME-Zarr output.

Every input is a flag, so the model can be rerun with one's own
measurements and network:  scripts/scale-model.py --help
"""
import argparse
import math


def frame_rows(a):
    pixels = a.width * a.height
    # Samples per pixel grow with the volume's edge at the same step in
    # voxels and the same view (the thesis view scaled).
    spp = a.spp_measured * a.edge / a.edge_measured
    samples = spp * pixels
    rows = []
    n = a.ranks_min
    while n <= a.ranks_max:
        ert = min(1.0 + a.ert_overhead * math.log2(n), a.no_ert_ratio)
        render = (samples * a.ns_per_sample * 1e-9 * ert * a.imbalance
                  / (n * a.cores * a.thread_efficiency))
        record = a.record_bytes + 1 / 8
        image = pixels * record
        rounds = int(math.log2(n))
        swap = 0.0
        for k in range(1, rounds + 1):
            piece = image / 2 ** k
            joins = pixels / 2 ** k
            swap += (a.latency_us * 1e-6 + piece / (a.bandwidth_gbs * 1e9)
                     + joins * a.ns_per_join * 1e-9 / a.composite_threads)
        gather = a.latency_us * 1e-6 * rounds + image * (1 - 1 / n) / (a.bandwidth_gbs * 1e9)
        decode = pixels * a.ns_per_decode * 1e-9
        total = render + swap + gather + decode
        voxels_per_rank = a.edge ** 3 * a.sample_bytes / n
        cells = (a.edge / a.cell) ** 3 * 8 / 7  # all levels
        index_gb = cells * 8 / 1e9  # min and max as f32
        rows.append((n, render, swap, gather + decode, total,
                     voxels_per_rank / 1e9, index_gb))
        n *= 2
    return samples, rows


def convert_rows(a):
    data = a.slices * a.slice_edge ** 2 * a.slice_bytes
    rows = []
    for n in a.shards:
        compute = data * a.convert_ns_per_byte * 1e-9 * a.apron / (n * a.cores * a.thread_efficiency)
        node_read = data * a.apron / n / (a.node_read_gbs * 1e9)
        fs_read = data * a.apron / (a.fs_gbs * 1e9)
        shard = max(compute, node_read, fs_read)
        merge = data * a.compression / (a.merge_gbs * 1e9)
        rows.append((n, compute, max(node_read, fs_read), shard, merge, shard + merge, shard))
    return data, rows


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    m = p.add_argument_group("measured (scripts/bench-mpi.sh, scripts/bench-shard.sh, this machine)")
    m.add_argument("--ns-per-sample", type=float, default=53.7,
                   help="one thread's frame time per DVR sample, set-up included (0.533 s / 9.92 M)")
    m.add_argument("--spp-measured", type=float, default=20.25,
                   help="DVR samples per pixel on the thesis view (9.92 M / 700x700)")
    m.add_argument("--edge-measured", type=float, default=800)
    m.add_argument("--ert-overhead", type=float, default=0.037,
                   help="extra samples per doubling of ranks from per-share early termination (2 ranks: 3.7%%)")
    m.add_argument("--record-bytes", type=float, default=24, help="DVR bytes per pixel record")
    m.add_argument("--ns-per-join", type=float, default=8.0,
                   help="encoding and compositing, per pixel and part, one thread (8 ms / 0.98 M)")
    m.add_argument("--ns-per-decode", type=float, default=16.0,
                   help="rank 0 gathering and decoding the image, per pixel, one thread (8 ms / 0.49 M)")
    m.add_argument("--convert-ns-per-byte", type=float, default=1.18,
                   help="TIFF slices to bricked:32 zstd, one thread (4.85 s / 4.1 GB)")
    m.add_argument("--apron", type=float, default=1.07,
                   help="sum of the shards over the unsharded job (4 shards: 1.07)")
    s = p.add_argument_group("assumed (the cluster, the data)")
    s.add_argument("--no-ert-ratio", type=float, default=3.0,
                   help="cap on the early-termination overhead: samples without it over samples "
                        "with it (not reached from 16 to 1024 ranks)")
    s.add_argument("--edge", type=float, default=10000)
    s.add_argument("--sample-bytes", type=float, default=1)
    s.add_argument("--cell", type=float, default=16, help="index cell edge (--cell)")
    s.add_argument("--width", type=int, default=3840)
    s.add_argument("--height", type=int, default=2160)
    s.add_argument("--ranks-min", type=int, default=16)
    s.add_argument("--ranks-max", type=int, default=1024)
    s.add_argument("--cores", type=int, default=32, help="cores per rank (one rank per node)")
    s.add_argument("--thread-efficiency", type=float, default=0.9)
    s.add_argument("--imbalance", type=float, default=1.1, help="slowest rank over the mean")
    s.add_argument("--bandwidth-gbs", type=float, default=12.5, help="per node (100 Gb/s)")
    s.add_argument("--latency-us", type=float, default=2.0)
    s.add_argument("--composite-threads", type=int, default=1,
                   help="threads compositing a piece (volkit today: 1)")
    s.add_argument("--slices", type=int, default=10000)
    s.add_argument("--slice-edge", type=int, default=10000)
    s.add_argument("--slice-bytes", type=int, default=2)
    s.add_argument("--shards", type=int, nargs="+", default=[16, 64, 256, 1024])
    s.add_argument("--node-read-gbs", type=float, default=2.0, help="one node reading the file system")
    s.add_argument("--fs-gbs", type=float, default=100.0, help="the file system in all")
    s.add_argument("--compression", type=float, default=0.5, help="zstd output over input")
    s.add_argument("--merge-gbs", type=float, default=2.0, help="one node copying the parts")
    a = p.parse_args()

    samples, rows = frame_rows(a)
    print(f"Frame: {a.edge:.0f}^3 u8 at {a.width}x{a.height}, DVR, {samples / 1e9:.1f} G samples, "
          f"{a.cores} cores per rank, {a.bandwidth_gbs} GB/s and {a.latency_us} us per link\n")
    print("| ranks | render | binary swap | gather + decode on rank 0 | frame | volume per rank | index per rank |")
    print("|---|---|---|---|---|---|---|")
    for n, render, swap, gather, total, vol, ix in rows:
        print(f"| {n} | {render:.3f} s | {swap * 1e3:.0f} ms | {gather * 1e3:.0f} ms | {total:.3f} s "
              f"| {vol:.0f} GB | {ix:.1f} GB |")
    data, crows = convert_rows(a)
    print(f"\nConversion: {a.slices} slices of {a.slice_edge}^2 x {a.slice_bytes} bytes "
          f"({data / 1e12:.1f} TB) to bricked:32 zstd\n")
    print("| shards | compute per shard | read per shard | slowest shard | merge to one .vvol | .vvol in all | OME-Zarr in all |")
    print("|---|---|---|---|---|---|---|")
    for n, compute, read, shard, merge, vvol, zarr in crows:
        print(f"| {n} | {compute:.0f} s | {read:.0f} s | {shard:.0f} s | {merge:.0f} s | {vvol:.0f} s | {zarr:.0f} s |")


if __name__ == "__main__":
    main()
