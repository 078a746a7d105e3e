#include <gshell/run/deform_run.h>

#include <gshell/deform/base_frames.h>
#include <gshell/error.h>
#include <gshell/format_number.h>
#include <gshell/geometry/validate_mesh.h>
#include <gshell/io/load_mesh.h>
#include <gshell/io/tet_mesh_io.h>
#include <gshell/io/write_mesh.h>
#include <gshell/quality/certificate_report.h>
#include <gshell/quality/stretch_report.h>
#include <gshell/run/frames.h>
#include <gshell/run/staged_folder.h>
#include <gshell/shell/offset_shell.h>
#include <gshell/shell/prism_tets.h>

#include "invalid_items_warning.h"
#include "io/file_bytes.h"
#include "run/output_folder_files.h"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <Eigen/SVD>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <future>
#include <memory>
#include <numeric>

namespace gshell {

namespace fs = std::filesystem;

namespace {

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const std::size_t h = v.size() / 2;
  return v.size() % 2 ? v[h] : 0.5 * (v[h - 1] + v[h]);
}

// Whether a frame is the rest base turned inside out: the least-squares linear map between them
// about their centroids, A = M C^+ with M = sum (f - f_mean)(r - a)^T and C = sum (r - a)(r - a)^T
// (a the rest centroid), reverses orientation clearly: det A < -0.1 sigma_max(A)^3. On a rest base
// flat to rounding (a plane, where a mirror is a turn and the top rightly follows) A has rank 2
// and det 0; a frame squashed flat, or twisted by whole turns about an axis (A's block across the
// axis then averages to about zero: the sign of det M was rounding for `animate --twist 720`), is
// not a mirror either. C^+ is the rest's, made once.
class MirrorTest {
public:
  explicit MirrorTest(const Eigen::MatrixXd& rest) : centred_(rest.rowwise() - rest.colwise().mean()) {
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> C(centred_.transpose() * centred_);
    Eigen::Vector3d inverse = Eigen::Vector3d::Zero();
    for (int k = 0; k < 3; ++k)
      if (C.eigenvalues()[k] > 1e-12 * C.eigenvalues()[2]) inverse[k] = 1 / C.eigenvalues()[k];
    pseudo_inverse_ = C.eigenvectors() * inverse.asDiagonal() * C.eigenvectors().transpose();
  }
  bool mirrors(const Eigen::MatrixXd& frame) const {
    const Eigen::Matrix3d A =
        (frame.rowwise() - frame.colwise().mean()).transpose() * centred_ * pseudo_inverse_;
    const double largest = Eigen::JacobiSVD<Eigen::Matrix3d>(A).singularValues()[0];
    return A.determinant() < -0.1 * largest * largest * largest;
  }

private:
  Eigen::MatrixXd centred_;       // the rest base minus its centroid
  Eigen::Matrix3d pseudo_inverse_; // C^+
};

// Writes frame folder `dir` for the shell vertices X (2n x 3).
void write_frame(const fs::path& dir, const DeformInput& input, const RestTets& rest, Eigen::MatrixXd X,
                 const Eigen::MatrixXi& tets, const Embedding& embedding) {
  fs::create_directory(dir);
  const int n = input.shell.num_base_vertices();
  TriMesh top = input.surface; // faces and UVs of the base
  top.V = X.bottomRows(n);
  write_mesh((dir / "top.obj").string(), top);
  if (!input.detail_name.empty()) {
    TriMesh carried = input.detail;
    carried.V = carry(embedding, X);
    write_mesh((dir / kDetailFile).string(), carried);
  }
  TetMesh tet_mesh;
  tet_mesh.T = tets;
  tet_mesh.cell_data.emplace_back("stretch", tet_stretch(rest, X));
  tet_mesh.cell_data.emplace_back("det_F", tet_deformation_determinants(rest, X));
  tet_mesh.X = std::move(X);
  write_tet_mesh((dir / "shell.vtu").string(), tet_mesh);
}

} // namespace

void DeformRunOptions::check() const { frame.check(); }

DeformInput load_deform_input(const std::string& shell_dir, const std::vector<std::string>& frames,
                              const std::string& embed) {
  DeformInput input;
  ShellFolder folder = read_shell_folder(shell_dir);
  input.shell_name = shell_dir;
  input.shell = std::move(folder.shell);
  input.surface = std::move(folder.surface);
  input.rest_warning = invalid_rest_shell_warning(shell_dir, folder.report, "frame");
  input.frame_names = expand_frame_arguments(frames);
  input.frames = BaseFrames::load(input.frame_names, input.shell);
  if (!embed.empty()) {
    std::vector<std::string> skipped;
    input.detail = read_mesh_or_builtin(embed, &input.detail_warnings, &skipped);
    require_usable_coordinates(input.detail.V, embed);
    require_usable_texture_coordinates(input.detail, embed);
    if (!skipped.empty()) input.detail_warnings.push_back(carried_data_warning(embed, skipped, "detail.obj"));
    input.detail_name = embed;
  }
  return input;
}


nlohmann::ordered_json frame_json(const FrameResult& r) {
  nlohmann::ordered_json j{{"iterations", r.iterations}, {"converged", r.converged}, {"energy", r.energy}};
  j.update(stretch_report(r.stretch));
  j["seconds"] = r.seconds;
  j["guard_setup_seconds"] = r.guard_setup_seconds;
  j["valid"] = r.valid;
  j["method"] = frame_method_name(r.method);
  j["resumed"] = r.resumed;
  j["fresh_top"] = r.fresh_top;
  j["base_nearly_touching"] = r.base_nearly_touching;
  j["substeps"] = r.substeps;
  j["guarded_iterations"] = r.guarded_iterations;
  j["thinned_vertices"] = r.thinned_vertices;
  j["zero_area_faces"] = r.zero_area_faces;
  const ShellCertificate& c = r.certificate;
  j["certificate"] = nlohmann::ordered_json{{"inverted_tets", c.inverted_tets},
                                            {"top_self_intersections", count_or_null(c.top_self_intersections)},
                                            {"top_base_intersections", count_or_null(c.top_base_intersections)},
                                            {"wall_intersections", count_or_null(c.wall_intersections)},
                                            {"nested_parts", count_or_null(c.nested_parts)},
                                            {"exact", ShellCertificate::exact},
                                            {"seconds", r.certificate_seconds}};
  j["base_self_intersections"] = count_or_null(c.base_self_intersections);
  j["unextrudable_vertices"] = r.unextrudable_vertices;
  j["rest_faults_only"] = r.rest_faults_only;
  return j;
}

nlohmann::ordered_json DeformFrameRecord::to_json() const {
  nlohmann::ordered_json j{{"frame", frame}, {"base", base}};
  j.update(frame_json(result));
  if (offset) j["offset"] = stretch_report(*offset);
  return j;
}

std::vector<std::string> DeformRun::warnings() const {
  detail::InvalidItems invalid;
  for (const DeformFrameRecord& f : frames)
    if (!f.result.valid)
      invalid.add(f.frame, f.result.certificate.base_self_intersections > 0, !f.result.unextrudable_vertices.empty(),
                  f.result.rest_faults_only, f.result.base_nearly_touching);
  std::vector<std::string> out;
  const std::string line =
      detail::invalid_items_warning(invalid, static_cast<int>(frames.size()), "frame", options.frame.allow_invalid);
  if (!line.empty()) out.push_back(line);
  // The outputs are numbered by position: a folder whose frame numbers skip (frame_0001,
  // frame_0003) ran without a word, its frame_0003 written as frame_0002.
  for (const DeformFrameRecord& f : frames) {
    const std::string extension = io_detail::lower_extension(f.base);
    const std::optional<int> k =
        frame_number(fs::path(f.base).filename().string(), extension.empty() ? "" : "." + extension);
    if (k && *k != f.frame) {
      out.push_back("the frames' numbers do not run 1, 2, 3 ...: " + f.base + " is frame " + std::to_string(f.frame) +
                    " of the run, and the outputs are numbered by position (" + frame_name(f.frame) + ")");
      break;
    }
  }
  std::vector<int> degenerate;
  int most = 0;
  for (const DeformFrameRecord& f : frames)
    if (f.result.zero_area_faces > 0) {
      degenerate.push_back(f.frame);
      most = std::max(most, f.result.zero_area_faces);
    }
  if (!degenerate.empty()) {
    out.push_back(detail::named_items("frame", degenerate) + (degenerate.size() == 1 ? " has" : " have") +
                  " base faces of zero area (up to " + std::to_string(most) +
                  " a frame: a collapsed edge or collinear corners): no prism over such a face has a valid shape, "
                  "and the base crossings counted there are those faces touching their neighbours");
  }
  std::vector<int> mirrored;
  for (const DeformFrameRecord& f : frames)
    if (f.mirrored) mirrored.push_back(f.frame);
  if (!mirrored.empty())
    out.push_back(detail::named_items("frame", mirrored) + (mirrored.size() == 1 ? " mirrors" : " mirror") +
                  " the rest base (a negative scale: the best linear map from the rest base reverses orientation): "
                  "the faces wind the other way round, so the top lies on the other side of the base, inside a "
                  "closed one, and the detail in it too");
  // A rest shell with flat or inverted tets deforms with their normal prisms as rest shapes
  // (deformation_rest_tets): each frame pushes them back to a proper prism, so the frames differ
  // from the rest shell there, and a rest top on the wrong side of its base turns right side out.
  if (replaced_rest_tets > 0)
    out.push_back(std::to_string(replaced_rest_tets) + " of " + std::to_string(tets) +
                  " rest shell tets are flat or inverted: they deform with their normal prism's shape as "
                  "rest shape, so the frames push them back to a proper prism" +
                  (2 * replaced_rest_tets > tets ? " (most are: is the rest top on the wrong side of the base? "
                                                   "the frames' tops will be on the other side)"
                                                 : ""));
  // As for pose steps: a frame cut off by the iteration cap may keep more stretch than its minimum.
  std::vector<int> capped;
  for (const DeformFrameRecord& f : frames)
    if (!f.result.converged) capped.push_back(f.frame);
  const std::string unconverged =
      detail::unconverged_items_warning("frame", capped, options.frame.max_iterations,
                                        "the top may be short of the frame's minimum; more iterations get closer");
  if (!unconverged.empty()) out.push_back(unconverged);
  if (embed && embed->max_outside_distance > thickness)
    out.push_back(std::to_string(embed->outside) + " of " + std::to_string(embed->points) + " detail vertices of " +
                  embed->detail + " lie outside the shell, up to " + format_number(embed->max_outside_distance) +
                  " from it (" + format_number(embed->max_outside_distance / thickness) +
                  " times its thickness): they follow their nearest tet extrapolated, so far ones move "
                  "far from the shell (other units?)");
  return out;
}

nlohmann::ordered_json DeformRun::to_json() const {
  using json = nlohmann::ordered_json;
  std::vector<double> seconds, iterations;
  double guard_setup_seconds = 0, volume_mean_sum = 0, max_stretch = 0, offset_volume_mean_sum = 0, offset_max = 0;
  int inverted = 0, offset_inverted = 0, unconverged = 0, valid = 0, guarded = 0, max_substeps = 0,
      certified_inverted = 0;
  for (const DeformFrameRecord& f : frames) {
    valid += f.result.valid ? 1 : 0;
    guarded += f.result.substeps > 0 ? 1 : 0;
    max_substeps = std::max(max_substeps, f.result.substeps);
    certified_inverted += f.result.certificate.inverted_tets;
    seconds.push_back(f.result.seconds);
    guard_setup_seconds += f.result.guard_setup_seconds;
    iterations.push_back(f.result.iterations);
    max_stretch = std::max(max_stretch, f.result.stretch.max);
    volume_mean_sum += f.result.stretch.volume_mean;
    inverted += f.result.stretch.inverted;
    unconverged += f.result.converged ? 0 : 1;
    if (f.offset) {
      offset_volume_mean_sum += f.offset->volume_mean;
      offset_max = std::max(offset_max, f.offset->max);
      offset_inverted += f.offset->inverted;
    }
  }
  const double count = std::max<double>(1, static_cast<double>(frames.size()));
  json summary{{"frames", frames.size()},
               {"median_seconds", median(seconds)},
               {"total_seconds", std::accumulate(seconds.begin(), seconds.end(), 0.0)},
               {"guard_setup_seconds", guard_setup_seconds},
               {"median_iterations", median(iterations)},
               {"max_iterations", iterations.empty() ? 0.0 : *std::max_element(iterations.begin(), iterations.end())},
               {"unconverged_frames", unconverged},
               {"mean_volume_stretch", volume_mean_sum / count},
               {"max_stretch", max_stretch},
               {"inverted_tets", inverted},
               {"valid_frames", valid},
               {"invalid_frames", static_cast<int>(frames.size()) - valid},
               {"certificate_inverted_tets", certified_inverted},
               {"guarded_frames", guarded},
               {"max_substeps", max_substeps}};
  if (options.compare_offset)
    summary["offset"] = json{{"mean_volume_stretch", offset_volume_mean_sum / count},
                             {"max_stretch", offset_max},
                             {"inverted_tets", offset_inverted}};
  json report{{"command", "deform"},
              {"shell", shell},
              {"base_vertices", base_vertices},
              {"tets", tets},
              {"thickness", thickness},
              {"tolerance", options.frame.tolerance},
              {"max_iterations", options.frame.max_iterations},
              {"warm_start", warm_start_name(options.frame.warm_start)},
              {"allow_invalid", options.frame.allow_invalid},
              {"replaced_rest_tets", replaced_rest_tets},
              {"factor_seconds", factor_seconds},
              {"setup_seconds", setup_seconds}};
  if (embed)
    report["embed"] = json{{"detail", embed->detail},
                           {"points", embed->points},
                           {"outside", embed->outside},
                           {"max_outside_distance", embed->max_outside_distance}};
  report["summary"] = summary;
  report["warnings"] = warnings();
  json list = json::array();
  for (const DeformFrameRecord& f : frames) list.push_back(f.to_json());
  report["frames"] = list;
  return report;
}

bool holds_only_deform_output(const fs::path& dir) {
  for (const auto& entry : fs::directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    if (name != kReportFile && name != kPreviewFile && !(entry.is_directory() && frame_number(name)))
      return false;
  }
  return true;
}

DeformRun run_deform(const DeformInput& input, const DeformRunOptions& options, const std::string& out,
                     const DeformProgress& progress, const BeforeCommit& before_commit) {
  using Clock = std::chrono::steady_clock;
  options.check();
  if (input.frames.size() != static_cast<int>(input.frame_names.size()))
    throw InputError("one name per base frame is needed");
  if (!(input.shell.thickness > 0)) throw InputError("the rest shell needs a positive thickness");
  std::unique_ptr<StagedFolder> staged; // fails on a bad output path before the long part
  if (!out.empty()) {
    check_output_folder(out, holds_only_deform_output);
    staged = std::make_unique<StagedFolder>(out);
  }
  const auto start = Clock::now();
  const Shell& shell = input.shell;
  const int n = shell.num_base_vertices();
  ShellDeformer deformer(shell);
  const Eigen::MatrixXi tets = build_prism_tets(shell.F, n);
  Embedding embedding;
  DeformRun run;
  if (!input.detail_name.empty()) {
    embedding = embed_points(shell.vertices(), tets, input.detail.V);
    run.embed = DeformRun::Embed{input.detail_name, embedding.size(), static_cast<int>(embedding.outside.size()),
                                 embedding.max_outside_distance};
  }
  run.shell = input.shell_name;
  run.base_vertices = n;
  run.tets = static_cast<int>(tets.rows());
  run.thickness = shell.thickness;
  run.options = options;
  run.replaced_rest_tets = deformer.replaced_rest_tets();
  run.factor_seconds = deformer.factor_seconds();
  run.setup_seconds = std::chrono::duration<double>(Clock::now() - start).count();
  const int count = input.frames.size();
  const MirrorTest mirror_test(shell.base);
  if (progress) progress(run, count);

  // Frames read again from their files (a sequence too large to hold): the next one is read while
  // this one is solved.
  const auto read_frame = [&input](int k) { return input.frames.get(k); };
  std::future<Eigen::MatrixXd> next;
  // A frame's files are written while the next frame is solved: at 1.3M shell vertices writing
  // them took longer than the solve. One write at a time; its error surfaces at the next frame's
  // write or before the report. Declared after `staged`, so that a run stopped by an error waits
  // for the write in flight before the staging folder is removed.
  std::future<void> writing;
  if (!input.frames.held()) next = std::async(std::launch::async, read_frame, 0);
  for (int k = 0; k < count; ++k) {
    DeformFrameRecord record;
    record.frame = k + 1;
    record.base = input.frame_names[k];
    const Eigen::MatrixXd base = next.valid() ? next.get() : input.frames.get(k);
    if (!input.frames.held() && k + 1 < count) next = std::async(std::launch::async, read_frame, k + 1);
    record.mirrored = mirror_test.mirrors(base);
    record.result = deformer.solve(base, options.frame);
    record.result.top.resize(0, 3); // in the folder, not in memory
    if (options.compare_offset) {
      Eigen::MatrixXd X(2 * n, 3);
      X << base, offset_top(base, shell.F, shell.thickness);
      record.offset = stretch_stats(deformer.rest_tets(), X);
    }
    if (staged) {
      if (writing.valid()) staged->write([&] { writing.get(); });
      writing = std::async(std::launch::async, write_frame, staged->path() / frame_name(k + 1, {}, count),
                           std::cref(input), std::cref(deformer.rest_tets()), deformer.current(), std::cref(tets),
                           std::cref(embedding));
    }
    run.frames.push_back(std::move(record));
    if (progress) progress(run, count);
  }
  if (staged) {
    staged->write([&] {
      if (writing.valid()) writing.get();
      write_report(staged->path() / kReportFile, run.to_json());
      if (before_commit) before_commit(staged->path());
    });
    staged->commit(holds_only_deform_output);
  }
  return run;
}

} // namespace gshell
