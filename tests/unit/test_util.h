#pragma once
// Small helpers shared by the unit tests.

#include "nebula/core/error.h"

#include <gtest/gtest.h>

#include <functional>
#include <string>

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

} // namespace nebula::test
