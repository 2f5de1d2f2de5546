// SPDX-License-Identifier: Apache-2.0
/// @file test_input.cpp
/// core/input.h: every input read once, as the stream it is: a regular file's size checked
/// before reading, a pipe refused as it passes the limit, the head checked after the first
/// bytes (so an endless stream is refused at once), folders and missing files named.

#include "nebula/core/input.h"

#include "nebula/core/error.h"

#include "test_util.h"

#include <gtest/gtest.h>

#include <chrono>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

namespace fs = std::filesystem;

using nebula::InputSpec;
using nebula::readInput;
using nebula::test::contains;
using nebula::test::errorMessage;

namespace {

using Input = nebula::test::TempFolder;

InputSpec jsonSpec(std::uint64_t limit)
{
    InputSpec spec;
    spec.option = "--stars";
    spec.format = "a JSON file";
    spec.limit = limit;
    spec.head = nebula::jsonHead("[", "a JSON array of stars");
    return spec;
}

TEST_F(Input, RegularFilesAreReadWholeWithinTheLimit)
{
    std::ofstream(path("a.json")) << "  [1, 2]\n";
    EXPECT_EQ(readInput(path("a.json"), jsonSpec(100)), "  [1, 2]\n");
    // One byte over: refused by its size, before reading; both sizes named.
    std::ofstream(path("b.json")) << "[" << std::string(100, ' ') << "]";
    const std::string msg = errorMessage([&] { readInput(path("b.json"), jsonSpec(100)); });
    EXPECT_EQ(msg, path("b.json") + " (--stars): the file has 102 B, more than the 100 B nebula "
                                    "reads of a JSON file (README, Failure behaviour)");
}

TEST_F(Input, HeadsAreCheckedAfterTheFirstBytes)
{
    std::ofstream(path("c.json")) << "\n\t {\"a\": 1}";
    EXPECT_EQ(errorMessage([&] { readInput(path("c.json"), jsonSpec(100)); }),
              path("c.json") + " (--stars): not a JSON array of stars: it starts with '{', "
                               "expected '['");
    std::ofstream(path("blank.json")) << " \n ";
    EXPECT_EQ(errorMessage([&] { readInput(path("blank.json"), jsonSpec(100)); }),
              path("blank.json") + " (--stars): empty: expected a JSON array of stars");
    // /dev/zero never ends: its first byte decides.
    const auto start = std::chrono::steady_clock::now();
    EXPECT_TRUE(contains(errorMessage([&] { readInput("/dev/zero", jsonSpec(1 << 30)); }),
                         "/dev/zero (--stars): not a JSON array of stars: it starts with byte "
                         "0x00"));
    EXPECT_LT(std::chrono::steady_clock::now() - start, std::chrono::seconds(5));
    // Text heads (config files) name the line and column of the first control byte.
    InputSpec text;
    text.option = "--config";
    text.format = "a config file";
    text.head = nebula::textHead();
    std::ofstream(path("c.toml"), std::ios::binary) << "res = 16\nseed\x01 = 2\n";
    EXPECT_EQ(errorMessage([&] { readInput(path("c.toml"), text); }),
              path("c.toml") + " (--config), line 2: byte 0x01 at column 5 is not text; a config "
                               "file holds lines \"key = value\"");
}

TEST_F(Input, PipesAreStreamsReadOnceUpToTheLimit)
{
    // A FIFO, as a process substitution gives: its bytes read once, as they arrive.
    const std::string fifo = path("f.json");
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
    std::thread writer([&] {
        std::ofstream out(fifo, std::ios::binary);
        out << "[" << std::string(5000, ' ') << "]";
    });
    EXPECT_EQ(readInput(fifo, jsonSpec(10000)).size(), 5002u);
    writer.join();
    // More than the limit: refused as it passes it, naming the limit.
    std::thread writer2([&] {
        std::signal(SIGPIPE, SIG_IGN);
        std::ofstream out(fifo, std::ios::binary);
        out << "[" << std::string(200000, ' ') << "]";
    });
    EXPECT_EQ(errorMessage([&] { readInput(fifo, jsonSpec(100000)); }),
              fifo + " (--stars): more than 97.7 KiB arrived, the most nebula reads of a JSON "
                     "file (README, Failure behaviour)");
    writer2.join();
}

TEST_F(Input, FoldersAndMissingFilesAreNamed)
{
    EXPECT_EQ(errorMessage([&] { readInput(dir.string(), jsonSpec(100)); }),
              dir.string() + " (--stars): is a folder, not a JSON file");
    EXPECT_EQ(errorMessage([&] { readInput(path("none.json"), jsonSpec(100)); }),
              path("none.json") + " (--stars): cannot open file (No such file or directory)");
    InputSpec vdb = jsonSpec(100);
    vdb.option = "-i";
    EXPECT_EQ(errorMessage([&] { readInput(path("none.vdb"), vdb); }),
              path("none.vdb") + ": cannot open file (No such file or directory)");
}

} // namespace

namespace {

/// This process's resident anonymous memory [bytes] (RssAnon in /proc/self/status).
std::uint64_t residentAnonymous()
{
    std::ifstream status("/proc/self/status");
    std::string key;
    while (status >> key) {
        if (key == "RssAnon:") {
            std::uint64_t kib = 0;
            status >> kib;
            return kib * 1024;
        }
        status.ignore(1 << 20, '\n');
    }
    return 0;
}

} // namespace

TEST_F(Input, RegularFilesAreMappedNotCopied)
{
    // 48 MiB with a JSON head: mapped, the same checks, the same bytes, no copy in this
    // process's anonymous memory (a read would add 48 MiB; allow 8 for the test's own noise).
    const std::size_t size = std::size_t(48) << 20;
    {
        std::string text = "[" + std::string(size - 2, ' ') + "]";
        for (std::size_t i = 1; i + 1 < size; i += 4099)
            text[i] = '1';
        std::ofstream(path("big.json"), std::ios::binary) << text;
    }
    const std::uint64_t before = residentAnonymous();
    const nebula::InputBytes bytes = nebula::mapInput(path("big.json"), jsonSpec(size));
    ASSERT_TRUE(bytes.mapped());
    const std::string_view v = bytes.view();
    ASSERT_EQ(v.size(), size);
    std::size_t ones = 0;
    for (const char c : v)
        ones += c == '1';
    EXPECT_EQ(ones, (size - 3) / 4099 + 1);
    EXPECT_LT(residentAnonymous(), before + (std::uint64_t(8) << 20));
    // Released pages read back the same bytes.
    bytes.release(0, size);
    EXPECT_EQ(v[0], '[');
    EXPECT_EQ(v[1], '1');
    EXPECT_EQ(v[size - 1], ']');
    // The same refusals as readInput(): over the limit (before mapping), a wrong head.
    EXPECT_EQ(errorMessage([&] { nebula::mapInput(path("big.json"), jsonSpec(size - 1)); }),
              path("big.json") + " (--stars): the file has 48 MiB, more than the 48 MiB nebula "
                                 "reads of a JSON file (README, Failure behaviour)");
    std::ofstream(path("c.json")) << "{}";
    EXPECT_EQ(errorMessage([&] { nebula::mapInput(path("c.json"), jsonSpec(100)); }),
              path("c.json") + " (--stars): not a JSON array of stars: it starts with '{', "
                               "expected '['");
    // Streams and empty files are read as readInput() reads them.
    std::ofstream(path("empty.json")).flush();
    EXPECT_EQ(errorMessage([&] { nebula::mapInput(path("empty.json"), jsonSpec(100)); }),
              path("empty.json") + " (--stars): empty: expected a JSON array of stars");
    const std::string fifo = path("f.json");
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
    std::thread writer([&] { std::ofstream(fifo, std::ios::binary) << "[1]"; });
    const nebula::InputBytes piped = nebula::mapInput(fifo, jsonSpec(100));
    writer.join();
    EXPECT_FALSE(piped.mapped());
    EXPECT_EQ(piped.view(), "[1]");
}

#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#define NEBULA_TEST_UNDER_ASAN 1
#endif
#endif
#if defined(__SANITIZE_ADDRESS__)
#define NEBULA_TEST_UNDER_ASAN 1
#endif

TEST_F(Input, AMappedFileThatShrinksIsAnErrorNotACrash)
{
    // Another program truncating the file while a tool reads it: the pages past the new end
    // raise SIGBUS; the tool names the file and exits 1.
    const std::size_t size = std::size_t(1) << 20;
    std::ofstream(path("shrinks.json"), std::ios::binary)
        << "[" << std::string(size - 2, ' ') << "]";
    const std::string file = path("shrinks.json");
#ifdef NEBULA_TEST_UNDER_ASAN
    // AddressSanitizer may keep SIGBUS to itself; it reports the fault and exits 1 too.
    const std::string shrankMessage;
#else
    const std::string shrankMessage = "error: " + file +
                                      " \\(--stars\\): the file shrank while it was read "
                                      "\\(another program truncated or rewrote it in place\\)";
#endif
    EXPECT_EXIT(
        {
            const nebula::InputBytes bytes = nebula::mapInput(file, jsonSpec(size));
            if (::truncate(file.c_str(), 4096) != 0) std::_Exit(3);
            volatile char c = bytes.view()[size - 1]; // past the new end
            (void)c;
            std::_Exit(4);
        },
        ::testing::ExitedWithCode(1), shrankMessage);
}
