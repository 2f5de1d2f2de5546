// SPDX-License-Identifier: Apache-2.0
#pragma once
// Small helpers shared by the unit tests.

#include "nebula/core/error.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <functional>
#include <iostream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

namespace nebula::test {

/// Message of the Error that @p f throws; fails the test if it throws none.
inline std::string errorMessage(const std::function<void()>& f)
{
    try {
        f();
    } catch (const nebula::Error& e) {
        return e.what();
    }
    ADD_FAILURE() << "no nebula::Error thrown";
    return {};
}

inline bool contains(const std::string& text, const std::string& part)
{
    return text.find(part) != std::string::npos;
}

/// A fresh, empty folder per test under the system's temporary folder, removed afterwards;
/// path() names a file in it.
class TempFolder : public ::testing::Test
{
protected:
    void SetUp() override
    {
        std::string pattern =
            (std::filesystem::temp_directory_path() / "nebula_test_XXXXXX").string();
        ASSERT_NE(::mkdtemp(pattern.data()), nullptr);
        dir = pattern;
    }
    void TearDown() override
    {
        std::error_code ec;
        std::filesystem::remove_all(dir, ec);
    }
    std::string path(const std::string& name) const { return (dir / name).string(); }

    std::filesystem::path dir;
};

/// Composite Simpson's rule over [a, b] with n (even) intervals.
inline double simpson(const std::function<double(double)>& f, double a, double b, int n)
{
    const double h = (b - a) / n;
    double sum = f(a) + f(b);
    for (int i = 1; i < n; ++i) {
        sum += (i % 2 == 1 ? 4.0 : 2.0) * f(a + i * h);
    }
    return sum * h / 3.0;
}

/// Captures std::cerr (rdbuf swap) for its lifetime.
class CerrCapture
{
public:
    CerrCapture() : mOld(std::cerr.rdbuf(mBuffer.rdbuf())) {}
    ~CerrCapture() { std::cerr.rdbuf(mOld); }
    CerrCapture(const CerrCapture&) = delete;
    CerrCapture& operator=(const CerrCapture&) = delete;
    std::string text() const { return mBuffer.str(); }

private:
    std::ostringstream mBuffer;
    std::streambuf* mOld;
};

/// A 3-vector of doubles for vector-field tests.
using Vec = std::array<double, 3>;

/// Jacobian J[i][j] = d v_i / d x_j of the field @p v at @p x by central differences of step h.
template <typename F> std::array<Vec, 3> jacobian(const F& v, const Vec& x, double h)
{
    std::array<Vec, 3> J{};
    for (int j = 0; j < 3; ++j) {
        Vec xp = x, xm = x;
        xp[j] += h;
        xm[j] -= h;
        const Vec vp = v(xp), vm = v(xm);
        for (int i = 0; i < 3; ++i)
            J[i][j] = (vp[i] - vm[i]) / (2.0 * h);
    }
    return J;
}

/// Frobenius norm of a 3x3 matrix.
inline double frobenius(const std::array<Vec, 3>& J)
{
    double s = 0.0;
    for (const auto& row : J)
        for (double x : row)
            s += x * x;
    return std::sqrt(s);
}

/// @p n points uniform in the cube [-halfSize, halfSize]^3 from seed @p seed.
inline std::vector<Vec> randomPoints(int n, double halfSize, unsigned seed)
{
    std::mt19937_64 rng(seed);
    std::uniform_real_distribution<double> u(-halfSize, halfSize);
    std::vector<Vec> pts(n);
    for (auto& p : pts)
        p = {u(rng), u(rng), u(rng)};
    return pts;
}

} // namespace nebula::test
