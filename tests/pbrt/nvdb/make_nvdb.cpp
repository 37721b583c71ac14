// Writes tests/pbrt/scenes/blob.nvdb, the NanoVDB test grid of the pbrt-v4 reader, with
// NanoVDB's own writer (the headers pbrt-v4 builds with: its src/ext/openvdb submodule,
// NanoVDB 32.3), ZIP-compressed as pbrt-v4 reads it, and prints the layout offsets the
// reader relies on.
//
//   g++ -std=c++17 -O1 -DNANOVDB_USE_ZIP -I PBRT_SRC/src/ext/openvdb/nanovdb make_nvdb.cpp \
//       -lz -o make_nvdb
//   ./make_nvdb ../scenes/blob.nvdb
//
// The file holds four float grids: "mask" (a decoy the reader must skip), "density", a fog
// volume of two soft blobs over negative and positive x index coordinates (two upper nodes,
// several lower nodes and leaves), "heat", a temperature over the first blob (named so
// that pbrt-v4 reads it only where a scene asks, "string temperaturename" "heat"), and
// "far", the density with one more voxel 620 voxels away, so that its box spans more voxels
// than the reader copies into a dense grid (it looks them up in the tree); voxel size 0.04,
// origin (-0.5, 0.1, -0.3).
#include <nanovdb/util/GridBuilder.h>
#include <nanovdb/util/IO.h>

#include <cmath>
#include <cstddef>
#include <cstdio>
#include <vector>

int main(int argc, char **argv) {
    if (argc < 2) {
        std::fprintf(stderr, "usage: make_nvdb OUT.nvdb\n");
        return 2;
    }
    using Root = nanovdb::NanoRoot<float>;
    using Upper = nanovdb::NanoUpper<float>;
    using Lower = nanovdb::NanoLower<float>;
    using Leaf = nanovdb::NanoLeaf<float>;
    std::printf("GridData %zu TreeData %zu RootData %zu Tile %zu\n",
                sizeof(nanovdb::GridData), sizeof(nanovdb::TreeData<3>),
                sizeof(Root::DataType), sizeof(Root::DataType::Tile));
    std::printf("upper table %zu size %zu; lower table %zu size %zu; leaf values %zu size %zu\n",
                offsetof(Upper::DataType, mTable), sizeof(Upper::DataType),
                offsetof(Lower::DataType, mTable), sizeof(Lower::DataType),
                offsetof(Leaf::DataType, mValues), sizeof(Leaf::DataType));
    std::printf("upper child mask %zu; lower child mask %zu; root background %zu\n",
                offsetof(Upper::DataType, mChildMask), offsetof(Lower::DataType, mChildMask),
                offsetof(Root::DataType, mBackground));

    nanovdb::GridBuilder<float> density(0.0f, nanovdb::GridClass::FogVolume);
    auto acc = density.getAccessor();
    for (int k = 0; k <= 17; ++k)
        for (int j = 0; j <= 19; ++j)
            for (int i = -12; i <= 13; ++i) {
                auto blob = [&](double ci, double cj, double ck, double r) {
                    double d2 = (i - ci) * (i - ci) + (j - cj) * (j - cj) + (k - ck) * (k - ck);
                    return std::exp(-d2 / (2 * r * r));
                };
                double v = 3.0 * blob(-4, 9, 8, 4) + 2.0 * blob(6, 11, 9, 3);
                if (v > 0.02) acc.setValue(nanovdb::Coord(i, j, k), float(v));
            }
    nanovdb::GridBuilder<float> far(0.0f, nanovdb::GridClass::FogVolume);
    auto facc = far.getAccessor();
    for (int k = 0; k <= 17; ++k)
        for (int j = 0; j <= 19; ++j)
            for (int i = -12; i <= 13; ++i) {
                float v = acc.getValue(nanovdb::Coord(i, j, k));
                if (v > 0.0f) facc.setValue(nanovdb::Coord(i, j, k), v);
            }
    facc.setValue(nanovdb::Coord(600, 610, 620), 0.5f);
    nanovdb::GridBuilder<float> mask(0.0f, nanovdb::GridClass::FogVolume);
    auto tacc = mask.getAccessor();
    tacc.setValue(nanovdb::Coord(0, 0, 0), 1000.0f);
    const nanovdb::Vec3d origin(-0.5, 0.1, -0.3);
    nanovdb::GridBuilder<float> heat(0.0f, nanovdb::GridClass::FogVolume);
    auto hacc = heat.getAccessor();
    for (int k = 2; k <= 14; ++k)
        for (int j = 3; j <= 15; ++j)
            for (int i = -10; i <= 2; ++i) {
                double d2 = (i + 4) * (i + 4) + (j - 9) * (j - 9) + (k - 8) * (k - 8);
                hacc.setValue(nanovdb::Coord(i, j, k), float(600 + 2400 * std::exp(-d2 / 18.0)));
            }
    std::vector<nanovdb::GridHandle<>> handles;
    handles.push_back(mask.getHandle<>(0.04, origin, "mask"));
    handles.push_back(density.getHandle<>(0.04, origin, "density"));
    handles.push_back(heat.getHandle<>(0.04, origin, "heat"));
    handles.push_back(far.getHandle<>(0.04, origin, "far"));
    nanovdb::io::writeGrids(argv[1], handles, nanovdb::io::Codec::ZIP);
    auto *g = handles[1].grid<float>();
    std::printf("density: %llu active voxels, index bbox (%d %d %d)-(%d %d %d)\n",
                (unsigned long long)g->activeVoxelCount(), g->indexBBox().min()[0],
                g->indexBBox().min()[1], g->indexBBox().min()[2], g->indexBBox().max()[0],
                g->indexBBox().max()[1], g->indexBBox().max()[2]);
    auto a = g->getAccessor();
    std::printf("value (-6 15 14) %.9g, (12 23 18) %.9g, (-1 7 3) %.9g, (27 35 31) %g\n",
                a.getValue({-6, 15, 14}), a.getValue({12, 23, 18}), a.getValue({-1, 7, 3}),
                a.getValue({27, 35, 31}));
    auto *f = handles[3].grid<float>();
    std::printf("far: index bbox (%d %d %d)-(%d %d %d)\n", f->indexBBox().min()[0],
                f->indexBBox().min()[1], f->indexBBox().min()[2], f->indexBBox().max()[0],
                f->indexBBox().max()[1], f->indexBBox().max()[2]);
    return 0;
}
