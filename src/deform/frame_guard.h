#pragma once
// The guard of a deformation's frames (ShellDeformer with allow_invalid off): step bounds that
// decide whether the paper's solve can be taken as it is, and the guarded solvers that drag the
// shell from the previous frame to the new base otherwise. Built once per rest shell and guard
// parameters; its solvers (two factorisations at most: with contacts, and tets only for bases
// that force a contact) are made at the first drag that needs them.
#include <gshell/deform/shell_deformer.h>
#include <gshell/guard/guarded_solver.h>
#include <gshell/quality/shell_boundary.h>
#include <gshell/quality/shell_certificate.h>

#include "quality/nested_parts.h"

#include <Eigen/Core>
#include <functional>
#include <memory>
#include <optional>
#include <vector>

namespace gshell {

/// A mend of a refused state weighed by the caller's energy (weighed_mend).
struct FrameMend {
  Eigen::MatrixXd X; ///< the mended state, 2n x 3; empty where the mend declined
  ShellCertificate certificate; ///< X's (mend's `certificate`)
  double energy = 0; ///< the caller's energy of X
  int iterations = 0; ///< the guarded solver's, also where the mend declined
  /// X's energy is at most (1 + max_rise) times the refused state's: X is to be taken as it is.
  /// A mend above that may sit in another minimum than a drag's: the caller drags too and keeps
  /// the valid state of lower energy (GuardOptions::mend_max_rise).
  bool within_rise = false;
};

class FrameGuard {
public:
  /// `rest`: the rest shell (the first frame starts from it), `rest_tets` the solver's rest
  /// shapes, `fixed` the vertices the caller moves (the base for a deformation, the handles for
  /// a pose); `moving_base`: the base is free, so base/base pairs count as the shell's own. Tets
  /// inverted at rest are left unguarded, and the boundary triangles of pairs that intersect or
  /// touch to rounding (pair_touches_to_rounding) at rest, with their neighbours, see no
  /// contacts, nor are those faces' prisms' tets guarded: what the rest shell breaks, the guard
  /// cannot keep.
  /// `arap`, when given, is the caller's solver for `rest_tets` with exactly `fixed` held (hard
  /// constraints, nothing soft): the guard's solvers share it instead of assembling and factoring
  /// the same system again. Without, the guard builds one at its first solve, shared by both its
  /// solvers.
  FrameGuard(const Shell& rest, std::shared_ptr<const RestTets> rest_tets, const GuardOptions& options,
             std::vector<int> fixed, bool moving_base, std::shared_ptr<const ShellSolver> arap = nullptr);
  ~FrameGuard();

  /// Whether this guard was built with these options.
  bool built_with(const GuardOptions& options) const;

  /// Whether X1 can be taken as the next frame after X0 (a frame made by this guard). With
  /// `contacts` (X0 free of contacts): X1's exact certificate (base/base pairs included where the
  /// base moves; returned in `certificate`, also when X1 is refused) finds nothing the guard keeps
  /// right, and every guarded tet keeps above keep_fraction of its X0 volume at X1 (the path to
  /// it does not matter). Without: the straight path from X0 to X1 keeps every guarded tet above
  /// keep_fraction of its volume. X1 is then a valid start for the guarded solver, as X0 is.
  bool accepts(const Eigen::MatrixXd& X0, const Eigen::MatrixXd& X1, bool contacts, ShellCertificate* certificate);
  /// The largest fraction t tried of the straight path from X0 to X1 whose end X0 + t (X1 - X0)
  /// this guard accepts (as `accepts` does: the path keeps every guarded tet above keep_fraction
  /// of its volume, the end's certificate finds nothing the guard keeps apart): the tet step
  /// bound first, then 0.7 of the last try, down to min_fraction. Returns 0 and leaves Y alone
  /// when no try is accepted, else t with Y = X0 + t (X1 - X0). `certificate`, if given, receives
  /// the exact certificate of the state chosen (X0 + t (X1 - X0), or X0 for 0), base/base pairs
  /// included where the base moves (as in `accepts`).
  double accepted_fraction(const Eigen::MatrixXd& X0, const Eigen::MatrixXd& X1, bool contacts, double min_fraction,
                           Eigen::MatrixXd& Y, ShellCertificate* certificate = nullptr);
  /// The exact certificate of X (2n x 3), base/base pairs included: certify_shell's answer, by
  /// the guard's certifier (trees refit, not rebuilt).
  ShellCertificate certify(const Eigen::MatrixXd& X);
  /// Whether a certificate finds nothing wrong that this guard keeps right: every inverted tet is
  /// one it leaves out (flat at rest, or at an unextrudable vertex), every intersecting pair
  /// touches a triangle it leaves out (around the rest's own intersections). With
  /// `near_left_out`, on guarded generation's terms instead: every pair touches a triangle that
  /// shares a vertex with one left out (those the contact guard cannot protect:
  /// GuardedShell::unprotected_triangles).
  bool only_unguarded_faults(const ShellCertificate& certificate, bool near_left_out = false) const;
  /// Chooses what the guard leaves out from the state `from` (2n x 3, a frame made by this guard)
  /// on: what the rest shell leaves out (above); the tets not positive at `from` (left inverted
  /// by an earlier choice) and, where the last choice left out more triangles than the rest's,
  /// the triangles around the crossings of `from`'s base; with `to` (2n x 3), also the tets of the
  /// prisms at vertices of `to`'s base that are unextrudable (extrusion_directions) and the
  /// triangles around its base's crossings with itself. A moving base can make a vertex
  /// unextrudable that was not at rest (CGAL's anchor twisted by 90 degrees), where one tet of
  /// its prisms must invert in a thin enough layer, or make the base cross itself (CGAL's
  /// triceratops bent by 90 degrees), where no top is clean: guarding them holds the frame back.
  /// The acceptance, the drags and only_unguarded_faults use the choice until the next call.
  /// Returns whether the choice changed.
  bool leave_out(const Eigen::MatrixXd& from, const Eigen::MatrixXd* to = nullptr);
  /// Whether the last leave_out left out more than the rest shell's choice.
  bool leaves_out_beyond_rest() const {
    return parameters_.skip_tets != rest_skip_ || parameters_.excluded_triangles != rest_excluded_;
  }
  /// Whether every fault the certificate finds lies where the rest shell itself is left out (its
  /// own inverted tets and intersections, its unextrudable vertices): a state with only those is
  /// as valid as its rest shell lets it be. False while more than the rest's is left out, and
  /// where the state's base crosses itself (a cause reported as such).
  bool only_rest_faults(const ShellCertificate& certificate) const {
    return certificate.base_self_intersections <= 0 && !leaves_out_beyond_rest() &&
           only_unguarded_faults(certificate);
  }
  /// Whether contacts are guarded at all (GuardOptions::contact_distance > 0).
  bool guards_contacts() const { return parameters_.contact_distance > 0; }

  struct Outcome {
    FrameMethod method = FrameMethod::Guarded;
    int substeps = 0;
    int iterations = 0;
    bool blocked = false; ///< stopped at contact (no fall-back to the tets): X valid, short of the targets
    bool superseded = false; ///< ended by `other_way` (see drag)
  };
  /// Mends X (2n x 3, a state this guard refused) where it is wrong instead of dragging the shell
  /// there: the top vertices of every violation are pulled towards their base vertices until X
  /// is valid (valid_start over X's own base, GuardOptions' start_* fields), and the guarded
  /// solver then moves them and `rings` (>= 0) rings around them, the rest held, to a minimum of
  /// the guarded energy. Taken when the exact certificate (base/base pairs included where the base
  /// moves, returned in `certificate`) finds only what the guard leaves out; no path from the
  /// refused state is asked for, its pulled-in tops thin their tets on purpose. Returns false and
  /// leaves X alone when contacts are not guarded, X's base crosses itself where the guard keeps
  /// contacts, the start gives up, a top it pulls in is a fixed vertex, or the certificate
  /// refuses the result. `refused`: X's certificate from `accepts`, if at hand (else X is
  /// certified again); `iterations` gets the solver's.
  bool mend(Eigen::MatrixXd& X, int rings, const GuardedSolveOptions& solve, const ShellCertificate* refused,
            ShellCertificate* certificate, int* iterations);
  /// mend() of a copy of X, then X's and the mended state's `energy` (the caller's objective)
  /// compared (FrameMend::within_rise).
  FrameMend weighed_mend(const Eigen::MatrixXd& X, int rings, double max_rise, const GuardedSolveOptions& solve,
                    const ShellCertificate* refused, const std::function<double(const Eigen::MatrixXd&)>& energy);
  /// Sub-steps for a drag from the state `from` to `to` (2n x 3): as many as keep every base edge
  /// vector's change per sub-step within schedule.substep_edge_change of its length, at least 1,
  /// at most schedule.max_substeps.
  int substeps_between(const Eigen::MatrixXd& from, const Eigen::MatrixXd& to, const DeformOptions& schedule) const;
  /// Drags X (2n x 3, a frame made by this guard) until its fixed vertices reach their rows of
  /// `targets`, in `substeps` straight pieces, each solved by the guarded solver: those before the
  /// last to the looser of `solve.tolerance` and `substep_tolerance`, the last to
  /// `solve.tolerance` with what the others left of substeps x `solve.max_iterations` (at least
  /// `solve.max_iterations`).
  /// Contacts are kept apart while the fixed vertices' motion allows it; when it forces one, only
  /// the tets are guarded from there on (TetsOnly) with `fall_back_to_tets`, else the drag stops
  /// where it is (blocked). Failed: X is left somewhere on the way. `contacts`: X is free of
  /// contacts (else only the tets can be guarded).
  /// `other_way` (optional) is asked at every stall, before the drag is retried or falls back to
  /// the tets: true means the caller has the frame by other means, and the drag ends there
  /// (`superseded`, X left where it stopped); false lets the drag go on (the caller may have
  /// changed the guard's choice of tets, leave_out, from X as it stands).
  /// `stage` (optional) is told each sub-step's name before its iterations, "drag K/N" (or
  /// "drag" for a single one), with " (tets only)" after the fall-back, for progress reports.
  Outcome drag(Eigen::MatrixXd& X, const Eigen::MatrixXd& targets, int substeps, bool contacts, bool fall_back_to_tets,
               const GuardedSolveOptions& solve, double substep_tolerance,
               const std::function<bool()>& other_way = {}, const std::function<void(const char*)>& stage = {});

private:
  GuardedSolver& tets_only();
  const std::shared_ptr<const ShellSolver>& arap();
  GuardedSolver& contact_solver();
  // The contact solver's supports capped at the rest shell (GuardOptions::contact_rest_fraction).
  void cap_contact_supports();


  GuardOptions options_;
  std::shared_ptr<const RestTets> rest_tets_; // shared with the caller's solver and this guard's own
  std::shared_ptr<const ShellSolver> arap_; // the ARAP system of both guarded solvers
  Eigen::MatrixXd rest_vertices_; // 2n x 3
  VolumeBarrier probe_; // the rest tets' relative volumes
  int n_ = 0;
  Eigen::MatrixXi F_;
  std::vector<int> fixed_;
  bool moving_base_ = false;
  ShellBoundary boundary_;
  ShellCertifier certifier_; // the rest shell's, then every frame's (its trees refit, not rebuilt)
  GuardedSolverParameters parameters_; // skip_tets, excluded_triangles: the last leave_out's
  std::vector<char> rest_skip_, rest_excluded_; // what the rest shell leaves out
  // The connected parts, made only when a certificate finds a sheet nested (never on one part).
  mutable std::optional<detail::ShellParts> parts_;
  std::vector<int> rest_nested_; // the certificate's nested probes at rest (vertices, ascending)
  std::unique_ptr<GuardedSolver> contact_, tets_;
};

} // namespace gshell
