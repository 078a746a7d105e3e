#pragma once
// Output folders written in one piece: everything goes into a hidden temporary folder beside the
// destination, which is renamed into place only when complete. A failure leaves nothing behind.
#include <gshell/error.h>
#include <gshell/io/temporary_outputs.h>

#include <filesystem>
#include <functional>
#include <optional>
#include <string>

namespace gshell {

/// The checks a StagedFolder for `destination` makes, so a command can fail on a bad output path
/// before its long part: the parent must be a folder, `destination` must not be a file, (when
/// `is_previous_output` is given) an existing non-empty `destination` must satisfy it, and a
/// folder must be creatable beside it (one is made and removed: read-only file systems, /proc).
/// Nothing is left behind. \throws InputError naming `destination`.
void check_output_folder(const std::filesystem::path& destination,
                         const std::function<bool(const std::filesystem::path&)>& is_previous_output = {});

class StagedFolder {
public:
  /// Creates the temporary folder ".NAME.tmp-PID-*" beside `destination` (the parent must exist),
  /// after removing those of `destination` that killed runs left (their process id names no
  /// process on this machine; a run on another machine writing the same folder at the same moment
  /// would lose its staging folder, as it would lose the race to the output anyway).
  /// \throws InputError naming the destination when it cannot.
  explicit StagedFolder(const std::filesystem::path& destination);
  /// Removes the temporary folder unless commit() succeeded.
  ~StagedFolder();
  StagedFolder(const StagedFolder&) = delete;
  StagedFolder& operator=(const StagedFolder&) = delete;

  /// Where to write: the temporary folder.
  const std::filesystem::path& path() const { return staging_; }

  /// Runs `write`, which writes into path(). An InputError it throws names the file where the user
  /// will look for it ("out/base.obj: write failed ..."), not in the hidden temporary folder
  /// ("./.out.tmp-141687477/base.obj: ...").
  template <class Write>
  decltype(auto) write(Write&& write) const {
    try {
      return write();
    } catch (const InputError& e) {
      throw InputError(at_destination(e.what()));
    }
  }
  /// `message` with the temporary folder's path replaced by the destination's.
  std::string at_destination(std::string message) const;

  /// Renames the temporary folder to the destination. An existing destination is replaced when it
  /// is an empty folder or `is_previous_output(destination)` says it holds an earlier output of the
  /// same command, so a mistyped -o never deletes unrelated files.
  /// \throws InputError naming the destination when it exists and is not an earlier output
  ///         ("exists and is not ... output") or the rename fails.
  void commit(const std::function<bool(const std::filesystem::path&)>& is_previous_output);

private:
  std::filesystem::path destination_, staging_;
  /// staging_, registered until committed (removed if the process is interrupted); empty once committed.
  std::optional<TemporaryOutput> registered_;
};

} // namespace gshell
