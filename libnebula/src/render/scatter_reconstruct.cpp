// SPDX-License-Identifier: Apache-2.0
/// @file scatter_reconstruct.cpp
/// nebscatter's tallies turned into the field's cells (scatter_reconstruct.h, DESIGN §5b).

#include "scatter_reconstruct.h"

#include "nebula/core/units.h"

#include <algorithm>
#include <cmath>

namespace nebula::detail {

namespace {

/// The world volume [pc^3] of field cell (I, J, K) (0-based) inside the walked box.
double cellWorldVolume(const Transport& tr, int I, int J, int K, double detA)
{
    const auto& fLo = tr.fieldLo();
    return tr.cellVolume({I + fLo[0], J + fLo[1], K + fLo[2]}) * detA;
}

} // namespace

FieldBlocks gatherBlocks(const Transport& tr, const SourceTallies& t, double U, double detA)
{
    FieldBlocks b;
    if (!tr.adaptive()) return b;
    b.lo = tr.blockLo();
    b.dims = tr.blockDims();
    const std::size_t per = std::size_t(tr.moments()) * std::size_t(tr.channels());
    b.per = per;
    b.index.assign(tr.blockRefined().size(), -1);
    const auto& fDims = tr.fieldDims();
    std::size_t nb = 0;
    // The blocks' own tallies, and their active cells' volume.
    for (int K = 0; K < fDims[2]; ++K)
        for (int J = 0; J < fDims[1]; ++J)
            for (int I = 0; I < fDims[0]; ++I) {
                const std::size_t c = (std::size_t(K) * fDims[1] + J) * fDims[0] + I;
                const double vol = cellWorldVolume(tr, I, J, K, detA);
                if (!(vol > 0.0) || tr.slots()[c] < 0) continue;
                std::int32_t& bi = b.index[tr.blockOf(c)];
                if (bi < 0) {
                    bi = std::int32_t(nb++);
                    b.value.resize(nb * per, 0.0);
                    b.volume.push_back(0.0);
                    b.s1.push_back(0.0);
                    b.sq.push_back(0.0);
                }
                b.volume[std::size_t(bi)] += vol;
                const std::int32_t slot = tr.slots()[c];
                if (tr.slotBlock()[std::size_t(slot)] >= 0) continue; // below
                const std::int64_t* v = t.sum.data() + std::size_t(slot) * per;
                for (std::size_t q = 0; q < per; ++q)
                    b.value[std::size_t(bi) * per + q] += double(v[q]);
            }
    // The refined blocks' cells' tallies, and the noise sums of the blocks tallied whole.
    const double quantum = t.quantum;
    for (std::size_t slot = 0; slot < tr.slotCount(); ++slot) {
        const std::int64_t blk = tr.slotBlock()[slot];
        if (blk < 0 || b.index[std::size_t(blk)] < 0) continue;
        const std::size_t bi = std::size_t(b.index[std::size_t(blk)]);
        const std::int64_t* v = t.sum.data() + slot * per;
        for (std::size_t q = 0; q < per; ++q)
            b.value[bi * per + q] += double(v[q]);
        b.s1[bi] = double(v[tr.noiseChannel()]) * quantum;
        b.sq[bi] = double(t.sq[slot]) * quantum * 256.0;
    }
    for (std::size_t bi = 0; bi < nb; ++bi)
        for (std::size_t q = 0; q < per; ++q)
            b.value[bi * per + q] *= quantum * U * tr.voxel() / b.volume[bi];
    return b;
}

void reconstructCell(const FieldBlocks& blocks, const int* X, float* m)
{
    int B[3];
    double offset[3];
    for (int a = 0; a < 3; ++a) {
        const int b = Transport::blockCoord(X[a]);
        B[a] = b - blocks.lo[a];
        offset[a] = X[a] - 2 * b == 0 ? -0.25 : 0.25;
    }
    const std::size_t own = std::size_t(blocks.row(B));
    std::int32_t lower[3], upper[3];
    for (int a = 0; a < 3; ++a) {
        int N[3] = {B[0], B[1], B[2]};
        N[a] = B[a] - 1;
        lower[a] = blocks.row(N);
        N[a] = B[a] + 1;
        upper[a] = blocks.row(N);
    }
    const std::size_t per = blocks.per;
    const std::vector<double>& value = blocks.value;
    for (std::size_t q = 0; q < per; ++q) {
        const double v = value[own * per + q];
        double result = v;
        for (int a = 0; a < 3; ++a) {
            if (lower[a] < 0 || upper[a] < 0) continue;
            const double dl = v - value[std::size_t(lower[a]) * per + q];
            const double du = value[std::size_t(upper[a]) * per + q] - v;
            if (!(dl * du > 0.0)) continue; // an extreme: flat
            const double mag =
                std::min({0.5 * std::abs(dl + du), 2.0 * std::abs(dl), 2.0 * std::abs(du)});
            result += std::copysign(mag, du) * offset[a];
        }
        m[q] = float(result);
    }
}

double fillFieldCells(const Transport& tr, const SourceTallies& t, const FieldBlocks& blocks,
                      double U, double detA, SparseVolume& moments, std::vector<float>* relError)
{
    const auto& fLo = tr.fieldLo();
    const auto& fDims = tr.fieldDims();
    const std::size_t per = std::size_t(tr.moments()) * std::size_t(tr.channels());
    const double quantum = t.quantum;
    const std::vector<double>& cellDust = tr.cellDust(); // the noise report's weights
    double errW = 0.0, errSum = 0.0;
    if (relError) {
        relError->assign(std::size_t(fDims[0]) * std::size_t(fDims[1]) * std::size_t(fDims[2]),
                         NOISE_INACTIVE);
    }
    for (int K = 0; K < fDims[2]; ++K)
        for (int J = 0; J < fDims[1]; ++J)
            for (int I = 0; I < fDims[0]; ++I) {
                const std::size_t c = (std::size_t(K) * fDims[1] + J) * fDims[0] + I;
                const double vol = cellWorldVolume(tr, I, J, K, detA);
                const std::int32_t slot = tr.slots()[c];
                if (!(vol > 0.0) || slot < 0) continue; // not active: stays 0
                const int X[3] = {I + fLo[0], J + fLo[1], K + fLo[2]};
                float* m = moments.writable(moments.index(X[0], X[1], X[2]));
                const std::int64_t blk = tr.adaptive() ? tr.slotBlock()[std::size_t(slot)] : -1;
                double s1 = 0.0, sq = 0.0, density = 0.0; // the noise report
                if (blk >= 0) {
                    reconstructCell(blocks, X, m);
                    const std::size_t bi = std::size_t(blocks.index[std::size_t(blk)]);
                    s1 = blocks.s1[bi];
                    sq = blocks.sq[bi];
                    density = s1 / blocks.volume[bi];
                } else {
                    const double scale = quantum * U * tr.voxel() / vol;
                    const std::int64_t* v = t.sum.data() + std::size_t(slot) * per;
                    for (std::size_t q = 0; q < per; ++q)
                        m[q] = float(double(v[q]) * scale);
                    s1 = double(v[tr.noiseChannel()]) * quantum;
                    sq = double(t.sq[std::size_t(slot)]) * quantum * 256.0;
                    density = s1 / vol;
                }
                // Y_00 folded out: the noise channel's J tally is t[c] / Y_00.
                const double rel = s1 > 0.0 ? std::sqrt(sq) / (s1 / (0.5 / std::sqrt(PI))) : 0.0;
                if (relError) (*relError)[c] = s1 > 0.0 ? float(rel) : NOISE_UNKNOWN;
                if (cellDust[c] > 0.0 && s1 > 0.0) {
                    const double wgt = cellDust[c] * density;
                    errW += wgt;
                    errSum += wgt * rel;
                }
            }
    return errW > 0.0 ? errSum / errW : 0.0;
}

void copyBorderCells(const Transport& tr, SparseVolume& moments)
{
    const auto& fLo = tr.fieldLo();
    const auto& fDims = tr.fieldDims();
    const int n = moments.channels();
    for (int K = 0; K < fDims[2]; ++K)
        for (int J = 0; J < fDims[1]; ++J)
            for (int I = 0; I < fDims[0]; ++I) {
                const int I2 = std::clamp(I, 1, fDims[0] - 2);
                const int J2 = std::clamp(J, 1, fDims[1] - 2);
                const int K2 = std::clamp(K, 1, fDims[2] - 2);
                if (I2 == I && J2 == J && K2 == K) continue;
                const float* src =
                    moments.voxel(moments.index(I2 + fLo[0], J2 + fLo[1], K2 + fLo[2]));
                float* dst = moments.writable(moments.index(I + fLo[0], J + fLo[1], K + fLo[2]));
                std::copy(src, src + n, dst);
            }
}

} // namespace nebula::detail
