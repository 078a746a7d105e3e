// An interrupted command leaves no file behind: the registry of outputs still being written, and
// `gshell deform -o OUT` stopped by SIGTERM or Ctrl-C (SIGINT) in the middle of its frames.
#include "test_support.h"

#include <gshell/error.h>
#include <gshell/io/atomic_file.h>
#include <gshell/io/temporary_outputs.h>
#include <gshell/run/staged_folder.h>

#include <gtest/gtest.h>

#include <chrono>
#include <csignal>
#include <cstring>
#include <fcntl.h>
#include <optional>
#include <spawn.h>
#include <string>
#include <sys/wait.h>
#include <thread>
#include <unistd.h>
#include <vector>

namespace fs = std::filesystem;
using namespace gshell;
using gshell::test::TempDir;

namespace {

/// Names in `dir`, hidden ones included.
std::vector<std::string> names_in(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.push_back(e.path().filename().string());
  return names;
}

/// The hidden staging folder of OUT (".OUT.tmp-*") in `dir`, if there is one.
std::optional<fs::path> staging_folder(const fs::path& dir, const std::string& out) {
  for (const auto& name : names_in(dir))
    if (name.rfind("." + out + ".tmp-", 0) == 0) return dir / name;
  return std::nullopt;
}

} // namespace

TEST(TemporaryOutputs, WhatIsStillBeingWrittenIsRemovedAndNothingElse) {
  TempDir dir("gshell-interrupts");
  const fs::path finished = dir.path() / "finished.txt";
  write_file_atomically(finished.string(), [](std::ostream& out) { out << "done\n"; });
  int removed = -1;
  {
    StagedFolder staged(dir.path() / "out");
    write_file_atomically((staged.path() / "frame.txt").string(), [](std::ostream& out) { out << "frame\n"; });
    // A file being written when the signal comes: registered from its creation to its rename. Its
    // writer then fails (the temporary is gone) and leaves nothing either.
    EXPECT_THROW(write_file_atomically((dir.path() / "report.json").string(), [&](std::ostream& out) {
                   out << "{}";
                   EXPECT_EQ(names_in(dir.path()).size(), 3u); // finished.txt, the staging folder, the temporary
                   removed = remove_temporary_outputs();
                 }),
                 InputError);
    EXPECT_EQ(removed, 2); // the staging folder (with its frame) and report.json's temporary
    EXPECT_FALSE(fs::exists(staged.path()));
  }
  // What was complete before stays, and nothing is registered any more.
  EXPECT_EQ(names_in(dir.path()), std::vector<std::string>{"finished.txt"});
  EXPECT_EQ(remove_temporary_outputs(), 0);
  EXPECT_TRUE(fs::exists(finished));
}

TEST(TemporaryOutputs, ACommittedFolderIsNoLongerTemporary) {
  TempDir dir("gshell-interrupts");
  StagedFolder staged(dir.path() / "out");
  write_file_atomically((staged.path() / "a.txt").string(), [](std::ostream& out) { out << "a\n"; });
  staged.commit({});
  EXPECT_EQ(remove_temporary_outputs(), 0);
  EXPECT_TRUE(fs::exists(dir.path() / "out" / "a.txt"));
}

class InterruptedDeform : public testing::TestWithParam<int> {};

TEST_P(InterruptedDeform, EndsAtOnceAndLeavesNothingBehind) {
  const int signal = GetParam();
  TempDir dir("gshell-interrupts");
  const auto cli = [&](const std::string& args) {
    const auto r = gshell::test::run_cli(args);
    ASSERT_EQ(r.exit_code, 0) << args << "\n" << r.err;
  };
  const std::string shell = dir.file("shell"), frames = dir.file("frames");
  cli("generate builtin:sphere:3 --thickness-ratio 0.03 -q -o " + shell);
  cli("animate builtin:sphere:3 --twist 60 --frames 2 -q -o " + frames);
  const fs::path work = dir.path() / "work";
  fs::create_directory(work);

  // Far more frames than the test waits for (two poses taken in turn, each a real solve).
  std::vector<std::string> args{GSHELL_CLI_PATH, "deform", "--shell", shell, "-o", "out", "--base"};
  for (int k = 0; k < 2000; ++k) args.push_back(frames + (k % 2 ? "/frame_0002.obj" : "/frame_0001.obj"));
  std::vector<char*> argv;
  for (std::string& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  const std::string err_file = dir.file("stderr.txt");
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addchdir_np(&actions, work.c_str());
  posix_spawn_file_actions_addopen(&actions, 2, err_file.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  // SIGINT as from a terminal: not ignored even if this test was started in the background.
  posix_spawnattr_t attributes;
  posix_spawnattr_init(&attributes);
  sigset_t defaults;
  sigemptyset(&defaults);
  sigaddset(&defaults, SIGINT);
  sigaddset(&defaults, SIGHUP);
  posix_spawnattr_setsigdefault(&attributes, &defaults);
  posix_spawnattr_setflags(&attributes, POSIX_SPAWN_SETSIGDEF);
  pid_t pid = 0;
  ASSERT_EQ(posix_spawn(&pid, GSHELL_CLI_PATH, &actions, &attributes, argv.data(), environ), 0);
  posix_spawn_file_actions_destroy(&actions);
  posix_spawnattr_destroy(&attributes);

  // Signal once the command has written two frames into its staging folder.
  const auto start = std::chrono::steady_clock::now();
  int status = 0;
  bool exited = false;
  for (;;) {
    if (waitpid(pid, &status, WNOHANG) == pid) {
      exited = true;
      break;
    }
    const auto staging = staging_folder(work, "out");
    if (staging && fs::exists(*staging / "frame_0002" / "top.obj")) break;
    if (std::chrono::steady_clock::now() - start > std::chrono::seconds(120)) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  ASSERT_FALSE(exited) << "gshell deform ended before it was interrupted: " << gshell::test::read_text(err_file);
  ASSERT_TRUE(staging_folder(work, "out").has_value()) << "no staging folder after 120 s";
  ASSERT_EQ(kill(pid, signal), 0);
  ASSERT_EQ(waitpid(pid, &status, 0), pid); // a hang here is the failure (ctest's timeout ends it)

  EXPECT_TRUE(WIFEXITED(status)) << status; // not killed by the signal
  EXPECT_EQ(WEXITSTATUS(status), 128 + signal);
  EXPECT_TRUE(names_in(work).empty()) << names_in(work).front(); // neither OUT nor its staging folder
  const std::string err = gshell::test::read_text(err_file);
  EXPECT_EQ(err.substr(err.rfind('\n', err.size() - 2) + 1), "gshell: interrupted\n") << err;
}

// SIGHUP (a closed terminal) and SIGQUIT (Ctrl-\\) killed the process and left the staging folder.
INSTANTIATE_TEST_SUITE_P(Signals, InterruptedDeform, testing::Values(SIGTERM, SIGINT, SIGHUP, SIGQUIT),
                         [](const testing::TestParamInfo<int>& info) { return "SIG" + std::string(sigabbrev_np(info.param)); });
