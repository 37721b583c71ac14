#!/usr/bin/env bash
# Builds the seed corpora under fuzz/corpus/TARGET from ../shared (CS184 scenes, environment
# maps) and from files the renderer writes itself (camera files, checkpoints, a small Radiance
# HDR). Nothing from ../shared is committed; run this once before fuzzing.
set -eu
cd "$(dirname "$0")/.."
SH=../shared
C=fuzz/corpus
mkdir -p $C/collada $C/camera $C/exr $C/hdr $C/checkpoint $C/obj $C/ply $C/gltf $C/pbrt $C/mitsuba $C/vol $C/nvdb $C/image
cargo build --release -q
BIN=target/release/pathtracer
if [ -d $SH/scenes ]; then
  find $SH/scenes -name '*.dae' -size -200k -exec cp {} $C/collada/ \;
  find $SH/envmaps -name '*.exr' -size -2M -exec cp {} $C/exr/ \;
  # OBJ seeds are the OBJ followed by an MTL of the same length (the target splits in half).
  for o in $SH/scenes/real/obj/*.obj; do
    m=${o%.obj}.mtl
    [ -f "$m" ] || m=/dev/null
    python3 -c 'import sys; a=open(sys.argv[1],"rb").read(); b=open(sys.argv[2],"rb").read()[:len(a)]; open(sys.argv[3],"wb").write(a+b.ljust(len(a), b" "))' "$o" "$m" "$C/obj/$(basename $o)"
  done
  find $SH/scenes/real/ply -name '*.ply' -size -200k -exec cp {} $C/ply/ \;
  # Self-contained glTF only (no external .bin): the .glb files.
  find $SH/scenes/real/gltf -name '*.glb' -exec cp {} $C/gltf/ \;
  for p in $SH/scenes/pbrt-v4/*/scene-v4.pbrt; do
    cp "$p" "$C/pbrt/$(basename "$(dirname "$p")").pbrt"
  done
  for m in $SH/scenes/mitsuba/*/scene_v3.xml; do
    cp "$m" "$C/mitsuba/$(basename "$(dirname "$m")").xml"
  done
else
  echo "NOTICE: ../shared not found; seeding from the project's own files only"
fi
cp tests/fixtures/*.dae $C/collada/
cp tests/mitsuba/scenes/*.xml $C/mitsuba/
# a scene followed by a NUL and a serialized mesh
cat tests/mitsuba/scenes/shapes.xml <(printf '\0') tests/mitsuba/scenes/shapes.serialized > $C/mitsuba/with_mesh.bin
cp tests/pbrt/scenes/*.pbrt $C/pbrt/
cp tests/mitsuba/scenes/*.vol $C/vol/
cp tests/pbrt/scenes/*.nvdb $C/nvdb/
cp tests/fixtures/*.gltf $C/gltf/
T=$(mktemp -d)
for spp in 1 2; do
  $BIN -s $spp -r 8 6 -f $T/o.png --save-camera $C/camera/cam$spp.txt --checkpoint $T/c$spp.ckpt >/dev/null 2>&1
  cp $T/c$spp.ckpt $C/checkpoint/
  # The same film without its digest, behind a byte 0x01: the target appends a valid digest.
  { printf '\001'; head -c -32 $T/c$spp.ckpt; } > $C/checkpoint/c$spp.body
done
$BIN -s 1 -r 16 8 -f $C/exr/small.exr >/dev/null 2>&1
python3 - "$C/hdr/small.hdr" <<'PY'
import sys
w, h = 16, 8
with open(sys.argv[1], "wb") as f:
    f.write(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y %d +X %d\n" % (h, w))
    for y in range(h):
        for x in range(w):
            f.write(bytes([x * 8, y * 16, 64, 128 + (x % 3)]))
PY
# Image seeds: a byte picking the extension (0 TGA, 1 PNG, 3 EXR, 4 HDR, 5 PFM), then the file.
for f in tests/pbrt/scenes/*.png tests/mitsuba/scenes/*.png; do { printf '\001'; cat "$f"; } > "$C/image/$(basename "$f").bin"; done
for f in tests/mitsuba/scenes/*.exr; do { printf '\003'; cat "$f"; } > "$C/image/$(basename "$f").bin"; done
{ printf '\004'; cat "$C/hdr/small.hdr"; } > "$C/image/small.hdr.bin"
{ printf '\005'; cat tests/pbrt/scenes/sky.pfm; } > "$C/image/sky.pfm.bin"
python3 - "$C/image" <<'PY'
import sys
# TGA: 24-bit raw bottom-up, 32-bit RLE top-down, grey RLE, colour-mapped (4x2 each).
def tga(kind, depth, desc, body, cmap=b"", entries=0):
    head = bytes([0, 1 if entries else 0, kind]) + (0).to_bytes(2, "little") + entries.to_bytes(2, "little")
    head += bytes([24 if entries else 0]) + bytes(4) + (4).to_bytes(2, "little") + (2).to_bytes(2, "little") + bytes([depth, desc])
    return head + cmap + body
cases = {
    "raw24": tga(2, 24, 0, bytes(range(24))),
    "rle32": tga(10, 32, 0x28, bytes([0x83, 1, 2, 3, 255, 0x03]) + bytes(range(16))),
    "grey_rle": tga(11, 8, 0x20, bytes([0x87, 200])),
    "cmap": tga(1, 8, 0, bytes([0, 1, 1, 0, 1, 0, 0, 1]), bytes([0, 0, 255, 255, 0, 0]), 2),
}
for name, data in cases.items():
    with open(f"{sys.argv[1]}/{name}.tga.bin", "wb") as f:
        f.write(b"\x00" + data + bytes(8) + b"TRUEVISION-XFILE.\x00")
PY
rm -rf "$T"
for t in collada camera exr hdr checkpoint obj ply gltf pbrt mitsuba vol nvdb image; do echo "$t: $(ls $C/$t | wc -l) seeds"; done
