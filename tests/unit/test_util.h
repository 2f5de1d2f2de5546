#pragma once
// Small helpers shared by the unit tests.

#include "nebula/error.h"

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

} // namespace nebula::test
