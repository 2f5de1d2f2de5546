// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file spectrum.h
/// Piecewise-linear spectra (DESIGN §7.1; Alghamdi et al. 2023): linear pieces on
/// non-overlapping wavelength intervals, exact sums, integrals and products, and merging of
/// neighbouring pieces under a tolerance. Groundwork for the spectral renderer.

#include <algorithm>
#include <cmath>
#include <cstddef>
#include <utility>
#include <vector>

namespace nebula {

/// One linear piece of a spectrum: the value m x + b on [x0, x1], 0 elsewhere. x is a
/// wavelength [nm]; the value is a spectral quantity (e.g. radiance per nm) in the caller's
/// unit, m is in that unit per nm. Invariant inside a Spectrum: x0 < x1.
struct Piece
{
    double x0; ///< left end [nm]
    double x1; ///< right end [nm]
    double m;  ///< slope [value unit / nm]
    double b;  ///< intercept: the line's value at x = 0 [value unit]

    /// Value of the piece's line at @p x [nm] (no check that x lies in [x0, x1]).
    double at(double x) const { return m * x + b; }
};

/// Relative tolerance under which two breakpoints count as equal (no slivers): x and y are
/// the same breakpoint when |x - y| <= BREAKPOINT_REL_TOL * max(|x|, |y|).
constexpr double BREAKPOINT_REL_TOL = 1e-12;

/// A piecewise-linear function of wavelength: a sum of Pieces kept as a list sorted by x0
/// with no overlaps (touching endpoints allowed). Values may be negative (absorption lines
/// are added as pieces with negative values, DESIGN §7.1).
class Spectrum
{
public:
    /// Adds @p p to the spectrum. Where p overlaps existing pieces, the overlap becomes pieces
    /// whose slope and intercept are the sums; the parts that do not overlap stay separate
    /// pieces. This is one sweep over the sorted breakpoints of p and of the pieces it
    /// overlaps, which reproduces all 11 cases of the paper's table (DESIGN §7.1). The
    /// affected pieces are found by binary search: O(log n + k) for k affected pieces, plus
    /// one move of the vector's tail when the piece count changes.
    /// An endpoint of p within BREAKPOINT_REL_TOL of an existing breakpoint is snapped to it.
    /// A piece of zero width (x0 == x1 within that tolerance) is ignored.
    /// Throws UsageError("spectrum piece with x0 > x1 ...") if p.x0 > p.x1 or an endpoint is
    /// not a number; use addTrapezoid() for endpoints that may come in either order.
    void add(const Piece& p);

    /// Adds the trapezoid through (@p x0, @p y0) and (@p x1, @p y1), x [nm], y in the
    /// spectrum's value unit. If x0 > x1 the endpoints are swapped together with their values
    /// (a Doppler shift that reverses the order, DESIGN §7.1). Its integral is
    /// (x1 - x0) (y0 + y1) / 2, up to rounding.
    void addTrapezoid(double x0, double x1, double y0, double y1);

    /// The sum of @p pieces (any order, overlaps allowed, each x0 <= x1 and finite), built
    /// by one sort and sweep over their endpoints: O(P log P) for P pieces, where adding them
    /// one by one costs O(P n). Equal to adding them with add() up to rounding; breakpoints
    /// within BREAKPOINT_REL_TOL of each other are one breakpoint, zero-width pieces are
    /// ignored, and no piece is made where none of the inputs is active (gaps stay gaps).
    /// Throws UsageError like add() on a reversed or non-finite piece.
    static Spectrum sum(std::vector<Piece> pieces);

    /// Multiplies every value by @p s (dimensionless or a unit conversion).
    void scale(double s);

    /// Value at @p x [nm]: the value of the piece whose half-open interval [x0, x1) contains
    /// x, the last piece's value at its own x1, and 0 outside every piece. At a point shared
    /// by two touching pieces this is the right-hand piece's value, never the sum.
    double operator()(double x) const;

    /// Exact integral over all wavelengths [value unit * nm].
    double integral() const;

    /// Exact integral of the product of this spectrum and @p other over all wavelengths:
    /// each overlapping pair of pieces contributes the integral of a quadratic (DESIGN §7.1),
    /// evaluated in the numerically stable Simpson form, which is exact for quadratics.
    /// A linear merge of the two sorted lists: O(n + m).
    double integral(const Spectrum& other) const;

    /// Merges neighbouring pieces i, j = i + 1 (left to right, repeatedly, so a run of
    /// similar pieces becomes one) when all of these hold, with w = x1_j - x0_i the width of
    /// their union:
    ///  - they touch: gap = x0_j - x1_i <= @p tolerance * w;
    ///  - their values at the join agree: |f_i(x1_i) - f_j(x0_j)|
    ///    <= tolerance * max(|f_i(x1_i)|, |f_j(x0_j)|);
    ///  - their slopes agree: |m_i - m_j| <= tolerance * max(|m_i|, |m_j|, 1e-300).
    /// The two are replaced by the single line over [x0_i, x1_j] with the same integral and
    /// the same first moment (integral of x f) as the pair (the gap counting as 0). Those two
    /// conditions are the normal equations of the least-squares fit, so the line is the exact
    /// L2-best line for the piecewise-linear input. The integral is always preserved (up to
    /// rounding), and so is the first moment. tolerance = 0 merges only exactly collinear,
    /// touching pieces.
    void merge(double tolerance);

    /// Multiplies the spectrum by a smooth function @p f (x [nm] -> factor), e.g.
    /// exp(-tau(x)) for extinction. Each piece's product p(x) = piece(x) f(x) is replaced by
    /// linear pieces interpolating p at their ends; a piece is halved recursively (at most
    /// MULTIPLY_MAX_DEPTH times) until the interpolant at its midpoint is within @p relTol of
    /// p there, relative to max |p| at its ends and midpoint.
    /// Accuracy: for a product whose second derivative is nearly constant on a final piece,
    /// the midpoint error is the largest error of the interpolant on it, so the pointwise
    /// error is about relTol times the local value and the error of the integral is about
    /// (2/3) relTol relative (the interpolant of a convex product lies above it). f must be
    /// smooth on the scale of the pieces: a midpoint check cannot see features it steps over.
    template <class F> void multiply(F&& f, double relTol);

    /// The pieces, sorted by x0, non-overlapping.
    const std::vector<Piece>& pieces() const { return mPieces; }

    /// Number of pieces.
    std::size_t size() const { return mPieces.size(); }

    /// Maximum recursion depth of multiply(): a piece is split into at most 2^20 pieces.
    static constexpr int MULTIPLY_MAX_DEPTH = 20;

private:
    /// Appends to @p out the linear pieces approximating f times the line through (a, pa) and
    /// (c, pc) on [a, c] (see multiply()).
    template <class F>
    static void multiplyPiece(const Piece& piece, F& f, double relTol, double a, double pa,
                              double c, double pc, int depth, std::vector<Piece>& out);

    std::vector<Piece> mPieces;
};

/// The piece through (@p x0, @p y0) and (@p x1, @p y1); x0 < x1 [nm].
Piece pieceThrough(double x0, double y0, double x1, double y1);

// ---------------------------------------------------------------------------------------------
// Template implementation

template <class F> void Spectrum::multiply(F&& f, double relTol)
{
    std::vector<Piece> out;
    out.reserve(mPieces.size());
    for (const Piece& p : mPieces) {
        const double pa = p.at(p.x0) * f(p.x0);
        const double pc = p.at(p.x1) * f(p.x1);
        multiplyPiece(p, f, relTol, p.x0, pa, p.x1, pc, 0, out);
    }
    mPieces = std::move(out);
}

template <class F>
void Spectrum::multiplyPiece(const Piece& piece, F& f, double relTol, double a, double pa, double c,
                             double pc, int depth, std::vector<Piece>& out)
{
    // Midpoint test of the linear interpolant of the product.
    const double mid = 0.5 * (a + c);
    const double pm = piece.at(mid) * f(mid);
    const double scaleAbs = std::max({std::fabs(pa), std::fabs(pc), std::fabs(pm)});
    if (depth >= MULTIPLY_MAX_DEPTH || std::fabs(pm - 0.5 * (pa + pc)) <= relTol * scaleAbs) {
        out.push_back(pieceThrough(a, pa, c, pc));
        return;
    }
    multiplyPiece(piece, f, relTol, a, pa, mid, pm, depth + 1, out);
    multiplyPiece(piece, f, relTol, mid, pm, c, pc, depth + 1, out);
}

} // namespace nebula
