#!/usr/bin/env python3
"""Independent check of Potree 2.0 folders against the .xyz file they were built from.

Written from the format (metadata.json, hierarchy.bin with 22-byte records and proxy chunks,
octree.bin with int32 positions, optional uint16 rgb and float intensity), not from pclx's
reader or writer, and using only the Python standard library. For every folder it checks that:
  - metadata "points" == the stored points == the input's rows minus rows with NaN/Inf,
  - the stored positions (and colours, intensities) are the input's as a multiset, within the
    scale,
    so a point stored twice or lost fails,
  - every point lies in its node's cube,
  - every node's byte range holds numPoints records and the ranges tile octree.bin,
  - child masks agree with the child records, proxies with the records they stand for,
  - no node is an empty leaf.

Usage: check_potree_additive.py INPUT POTREE_DIR [POTREE_DIR ...]   (exit 1 on failure)
INPUT: .xyz ("x y z [r g b]") or an ASCII .pcd with fields x y z and intensity.
"""
import collections
import json
import math
import os
import struct
import sys

RECORD = struct.Struct("<BBIqq")  # type, childMask, numPoints, byteOffset, byteSize
NORMAL, LEAF, PROXY = 0, 1, 2


class CheckError(Exception):
    """A property of the folder that does not hold."""


def to_float32(v):
    """The value as a C float holds it (the builder parses text into float)."""
    return struct.unpack("<f", struct.pack("<f", v))[0]


def float_bits(v):
    """The bits of v as a C float: intensities are compared exactly."""
    return struct.unpack("<I", struct.pack("<f", v))[0]


def read_pcd_intensity(path):
    """Valid rows of an ASCII .pcd as tuples (x, y, z, intensity bits) and the invalid row count."""
    rows, invalid = [], 0
    with open(path) as f:
        fields = None
        for line in f:
            words = line.split()
            if words and words[0] == "FIELDS":
                fields = words[1:]
            if words and words[0] == "DATA":
                if words[1] != "ascii" or fields is None:
                    raise CheckError("%s: only ASCII .pcd files with a FIELDS line are read" % path)
                break
        at = [fields.index(n) for n in ("x", "y", "z", "intensity")]
        for line in f:
            values = line.split()
            if not values:
                continue
            xyz = [float(values[i]) for i in at[:3]]
            if not all(math.isfinite(v) for v in xyz):
                invalid += 1
                continue
            rows.append(tuple(to_float32(v) for v in xyz) + (float_bits(float(values[at[3]])),))
    return rows, invalid


def read_input(path):
    """Valid rows of an .xyz file as tuples (x, y, z[, r, g, b]) and the invalid row count."""
    if path.endswith(".pcd"):
        return read_pcd_intensity(path)
    rows, invalid = [], 0
    with open(path) as f:
        for line in f:
            tokens = line.replace(",", " ").split()
            if not tokens:
                continue
            xyz = [float(t) for t in tokens[:3]]
            if not all(math.isfinite(v) for v in xyz):
                invalid += 1
                continue
            rgb = tuple(int(t) for t in tokens[3:6])
            rows.append(tuple(to_float32(v) for v in xyz) + rgb)
    return rows, invalid


def parse_hierarchy(data, first_chunk_size, step):
    """Nodes by name: dict name -> (type, mask, points, offset, size); checks chunk layout."""
    nodes = {}
    chunks = [("r", 0, first_chunk_size)]
    covered = []
    while chunks:
        root, offset, size = chunks.pop(0)
        if size <= 0 or size % RECORD.size or offset + size > len(data):
            raise CheckError("hierarchy chunk of %s at %d+%d is malformed" % (root, offset, size))
        covered.append((offset, size))
        queue = [root]
        count = size // RECORD.size
        for i in range(count):
            if i >= len(queue):
                raise CheckError("chunk of %s has %d records but its masks name %d" % (root, count, len(queue)))
            name = queue[i]
            rec = RECORD.unpack_from(data, offset + i * RECORD.size)
            kind, mask, points = rec[0], rec[1], rec[2]
            if kind == PROXY:
                if len(name) - len(root) != step:
                    raise CheckError("proxy %s is not on its chunk's bottom level" % name)
                if name in nodes:
                    raise CheckError("node %s appears twice" % name)
                nodes[name] = ("proxy", mask, points)
                chunks.append((name, rec[3], rec[4]))
                continue
            if i == 0 and name != "r":
                proxy = nodes.get(name)
                if proxy is None or proxy[0] != "proxy":
                    raise CheckError("chunk of %s has no proxy" % name)
                if proxy[1] != mask or proxy[2] != points:
                    raise CheckError("proxy of %s disagrees with its record (mask/points)" % name)
            elif name in nodes:
                raise CheckError("node %s appears twice" % name)
            if len(name) - len(root) == step and mask and kind != PROXY:
                raise CheckError("node %s has children on a chunk's bottom level but is no proxy" % name)
            nodes[name] = rec
            for c in range(8):
                if mask & (1 << c):
                    queue.append(name + str(c))
        if len(queue) != count:
            raise CheckError("chunk of %s: masks name %d records, it has %d" % (root, len(queue), count))
    covered.sort()
    at = 0
    for offset, size in covered:
        if offset != at:
            raise CheckError("hierarchy.bin chunks do not tile the file (gap or overlap at %d)" % at)
        at += size
    if at != len(data):
        raise CheckError("hierarchy.bin has %d bytes no chunk uses" % (len(data) - at))
    return nodes


def check_folder(folder, rows):
    with open(os.path.join(folder, "metadata.json")) as f:
        meta = json.load(f)
    with open(os.path.join(folder, "hierarchy.bin"), "rb") as f:
        hierarchy = f.read()
    with open(os.path.join(folder, "octree.bin"), "rb") as f:
        octree = f.read()
    names = [a["name"] for a in meta["attributes"]]
    bpp = sum(a["size"] for a in meta["attributes"])
    if names[0] != "position" or any(n not in ("position", "rgb", "intensity") for n in names):
        raise CheckError("unexpected attributes %s" % names)
    starts = {}
    for a in meta["attributes"]:
        starts[a["name"]] = sum(b["size"] for b in meta["attributes"][:meta["attributes"].index(a)])
    has_rgb = "rgb" in names
    has_intensity = "intensity" in names
    if has_intensity:
        check_intensity_attribute(meta["attributes"][names.index("intensity")])
    scale, offset = meta["scale"], meta["offset"]
    bmin, bmax = meta["boundingBox"]["min"], meta["boundingBox"]["max"]
    h = meta["hierarchy"]
    nodes = parse_hierarchy(hierarchy, h["firstChunkSize"], h["stepSize"])

    stored = collections.Counter()
    intensities = []
    ranges = []
    total, depth = 0, 0
    for name, rec in nodes.items():
        kind, mask, points, byte_offset, byte_size = rec
        level = len(name) - 1
        depth = max(depth, level)
        if kind not in (NORMAL, LEAF) or (kind == LEAF) != (mask == 0):
            raise CheckError("node %s: type %d with child mask %d" % (name, kind, mask))
        for c in range(8):
            if bool(mask & (1 << c)) != ((name + str(c)) in nodes):
                raise CheckError("node %s: child mask bit %d disagrees with the records" % (name, c))
        if points == 0 and mask == 0:
            raise CheckError("node %s is an empty leaf" % name)
        if byte_size != points * bpp:
            raise CheckError("node %s: %d points but %d bytes" % (name, points, byte_size))
        if byte_offset < 0 or byte_offset + byte_size > len(octree):
            raise CheckError("node %s: bytes %d+%d outside octree.bin" % (name, byte_offset, byte_size))
        if byte_size:
            ranges.append((byte_offset, byte_size, name))
        # The node's cube from the root cube and the child digits (x << 2 | y << 1 | z).
        lo, hi = list(bmin), list(bmax)
        for digit in name[1:]:
            d = int(digit)
            for axis, bit in ((0, 4), (1, 2), (2, 1)):
                mid = 0.5 * (lo[axis] + hi[axis])
                if d & bit:
                    lo[axis] = mid
                else:
                    hi[axis] = mid
        for k in range(points):
            at = byte_offset + k * bpp
            q = struct.unpack_from("<iii", octree, at)
            for axis in range(3):
                v = q[axis] * scale[axis] + offset[axis]
                if v < lo[axis] - scale[axis] or v > hi[axis] + scale[axis]:
                    raise CheckError("node %s: point %d lies outside its cube (axis %d: %.9g not in [%.9g, %.9g])"
                                     % (name, k, axis, v, lo[axis], hi[axis]))
            key = q + (struct.unpack_from("<HHH", octree, at + starts["rgb"]) if has_rgb else ())
            if has_intensity:
                bits = struct.unpack_from("<I", octree, at + starts["intensity"])[0]
                key += (bits,)
                value = struct.unpack("<f", struct.pack("<I", bits))[0]
                if math.isfinite(value):
                    intensities.append(value)
            stored[key] += 1
        total += points
    ranges.sort()
    at = 0
    for byte_offset, byte_size, name in ranges:
        if byte_offset != at:
            raise CheckError("octree.bin: node %s starts at %d, expected %d (overlap or gap)" % (name, byte_offset, at))
        at += byte_size
    if at != len(octree):
        raise CheckError("octree.bin has %d bytes no node uses" % (len(octree) - at))
    if h["depth"] != depth:
        raise CheckError("metadata depth %d, deepest node %d" % (h["depth"], depth))
    if meta["points"] != total:
        raise CheckError("metadata points %d, stored %d" % (meta["points"], total))
    if total != len(rows):
        raise CheckError("stored %d points, the input has %d valid rows (%.3fx)" % (total, len(rows), total / max(1, len(rows))))
    if has_intensity:
        attribute = meta["attributes"][names.index("intensity")]
        if intensities and (attribute["min"][0] != min(intensities) or attribute["max"][0] != max(intensities)):
            raise CheckError("intensity range [%g, %g] in the metadata, [%g, %g] stored" %
                             (attribute["min"][0], attribute["max"][0], min(intensities), max(intensities)))
    match_input(rows, stored, scale, offset, has_rgb, has_intensity)
    return len(nodes), total


def check_intensity_attribute(attribute):
    """Intensity as written: one float per point (PCL's type, unrounded)."""
    if attribute["type"] != "float" or attribute["size"] != 4 or attribute["numElements"] != 1:
        raise CheckError("intensity attribute %s is not one float" % attribute)


def match_input(rows, stored, scale, offset, has_rgb, has_intensity):
    """Takes each input row out of the stored multiset at its quantum or a neighbouring one."""
    def quantum(p):
        return tuple(int(math.floor((p[a] - offset[a]) / scale[a] + 0.5)) for a in range(3))

    def colour(p):
        """The stored attributes after the position: rgb (8 bits × 257) or intensity bits."""
        if has_rgb:
            return tuple(c * 257 for c in p[3:6])
        return (p[3],) if has_intensity else ()

    missed = []
    for p in rows:
        key = quantum(p) + colour(p)
        if stored[key] > 0:
            stored[key] -= 1
        else:
            missed.append(p)
    for p in missed:
        q = quantum(p)
        found = None
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                for dz in (-1, 0, 1):
                    key = (q[0] + dx, q[1] + dy, q[2] + dz)
                    near = all(abs(key[a] * scale[a] + offset[a] - p[a]) <= scale[a] for a in range(3))
                    if near and stored[key + colour(p)] > 0:
                        found = key + colour(p)
        if found is None:
            raise CheckError("input point %s is not stored (within the scale %s)" % (p, scale))
        stored[found] -= 1
    extra = sum(v for v in stored.values() if v > 0)
    if extra:
        raise CheckError("%d stored points are not input points" % extra)


def main(argv):
    if len(argv) < 3:
        print(__doc__, file=sys.stderr)
        return 2
    rows, invalid = read_input(argv[1])
    failed = False
    for folder in argv[2:]:
        try:
            nodes, total = check_folder(folder, rows)
            print("%s: OK, %d nodes, %d points stored once (%d invalid rows dropped)" % (folder, nodes, total, invalid))
        except (CheckError, OSError, ValueError, KeyError, struct.error) as e:
            print("%s: FAILED: %s" % (folder, e), file=sys.stderr)
            failed = True
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
