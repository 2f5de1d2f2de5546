// SPDX-License-Identifier: Apache-2.0
// nebview on the command line: the URL as the first line of stdout, and every bad input
// refused at start with a clear error (a port in use, an input without tau grids, a
// --path-out that cannot be written, a path file that does not parse).
#include "cli_fixture.h"

#include <gtest/gtest.h>

#include <fstream>
#include <regex>

using namespace nebula::clitest;

TEST_F(Cli, NebviewPrintsItsUrlFirstAndServesThePage)
{
    makeLit();
    // Started in the background; the URL is read from its first line of stdout.
    const Result r =
        run("(nebview -i lit.vdb --path-out p.json > url.txt & echo $! > pid.txt); "
            // Until the URL is there or nebview has gone: a condition, not a time.
            "while [ ! -s url.txt ] && kill -0 $(cat pid.txt) 2>/dev/null; do sleep 0.05; done; "
            "curl -s -o page.html -w '%{http_code}' \"$(head -1 url.txt)\" > code.txt; "
            "curl -s -o /dev/null -w '%{http_code}' \"$(head -1 url.txt | "
            "sed 's/token=.*/token=x/')\" > denied.txt; kill $(cat pid.txt)");
    EXPECT_EQ(r.code, 0) << r.err;
    std::ifstream url(path("url.txt"));
    std::string first;
    std::getline(url, first);
    EXPECT_TRUE(
        std::regex_match(first, std::regex("http://127\\.0\\.0\\.1:[0-9]+/\\?token=[0-9a-f]{32}")))
        << first;
    std::ifstream code(path("code.txt")), denied(path("denied.txt"));
    std::string c, d;
    code >> c;
    denied >> d;
    EXPECT_EQ(c, "200");
    EXPECT_EQ(d, "403");
    EXPECT_FALSE(fs::exists(path("p.json"))); // nothing written until Save
}

TEST_F(Cli, NebviewRefusesBadInputsAtStart)
{
    makeLit();
    // A port in use: named, exit 1.
    // The port file appears whole (renamed into place) once the port is taken; the test waits
    // for it, however busy the machine, and gives up only if the holder has died.
    const Result busy = run("python3 -c 'import os,socket,time,sys; s=socket.socket(); "
                            "s.bind((\"127.0.0.1\",0)); s.listen(); "
                            "open(\"port.tmp\",\"w\").write(str(s.getsockname()[1])); "
                            "os.rename(\"port.tmp\",\"port.txt\"); time.sleep(600)' & "
                            "while [ ! -s port.txt ]; do kill -0 $! 2>/dev/null || exit 99; "
                            "sleep 0.05; done; "
                            "nebview -i lit.vdb --port $(cat port.txt); e=$?; kill %1; "
                            "rm port.txt; exit $e");
    EXPECT_EQ(busy.code, 1) << busy.err;
    EXPECT_NE(busy.err.find("in use"), std::string::npos) << busy.err;
    EXPECT_NE(busy.err.find("127.0.0.1:"), std::string::npos) << busy.err;
    // An input without tau grids: nebrender's message.
    const Result view = run("nebview -i small.vdb");
    const Result render = run("nebrender -i small.vdb -o x.exr");
    EXPECT_EQ(view.code, render.code);
    EXPECT_NE(view.code, 0);
    const auto message = [](const std::string& err) { return err.substr(err.find("error: ")); };
    EXPECT_EQ(message(view.err), message(render.err));
    // --path-out that cannot be written: refused now, not at the first save.
    expectFailure("nebview -i lit.vdb --path-out missing/dir/p.json", 1, "--path-out");
    // --path-out is checked at start as every output is: not an input, not a FIFO, a device
    // or a symbolic link (without --write-through), a .json name.
    const std::string before = fileBytes("lit.vdb");
    expectFailure("nebview -i lit.vdb --path-out lit.vdb", 2, "--path-out lit.vdb is the input");
    EXPECT_EQ(fileBytes("lit.vdb"), before);
    expectFailure("nebview -i lit.vdb --path-out /dev/null", 2, "a character device");
    run("mkfifo fifo.json && ln -s lit.vdb link.json");
    expectFailure("nebview -i lit.vdb --path-out fifo.json", 2, "a FIFO");
    expectFailure("nebview -i lit.vdb --path-out link.json", 2,
                  "--path-out link.json is the input");
    run("ln -s elsewhere.json dangling.json");
    expectFailure("nebview -i lit.vdb --path-out dangling.json", 2, "a symbolic link");
    expectFailure("nebview -i lit.vdb --path-out path.txt", 2, "but this output is JSON");
    // A path file that does not parse.
    std::ofstream(path("bad.json")) << "{\"fps\": 24, \"keyframes\": [";
    expectFailure("nebview -i lit.vdb --camera-path bad.json", 1, "bad.json");
    expectFailure("nebview -i lit.vdb --listen 127.0.0.1", 2, "--listen");
    expectFailure("nebview -i lit.vdb --listen nowhere:80", 2, "not an IP address");
    expectFailure("nebview -i lit.vdb --res 0x10", 2, "--res");
    expectFailure("nebview -i lit.vdb --fast-step 0", 2, "--fast-step");
}
