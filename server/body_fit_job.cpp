// The body-fit job: collecting frame sets on the mask thread, fitting on a thread of its own, and
// applying the fitted body for the tracker.
#include "server/body_fit_job.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "drivers/thread_name.h"
#include "server/log.h"
#include "server/recording_control.h"
#include "server/stats.h"
#include "tracker/search/acquire.h"

namespace mocap {
namespace {

// A body fit gives up when no frame set with every camera's silhouettes came for this long (as a
// background capture does): a stalled camera must not hold the RPC forever.
constexpr int64_t kFitStallNs = 3'000'000'000;
// A body fit takes a frame set this often: 5 sets span 2 s, in which a subject asked to turn in
// the fit pose turns by some tens of degrees.
constexpr double kFitSetIntervalSeconds = 0.5;

FitBodyResult fitFailure(BodyFitError error, std::string message) {
  FitBodyResult result;
  result.error = error;
  result.message = std::move(message);
  return result;
}

void logFit(const FitBodyResult& result) {
  std::ostringstream proportions;
  for (int k = 0; k < BodyProportions::kCount; ++k)
    proportions << (k ? ", " : "") << BodyProportions::name(k) << " " << std::fixed
                << std::setprecision(3) << result.fit.proportions[k];
  logInfo() << "body fitted from " << result.frame_sets_used << " frame sets in " << std::fixed
            << std::setprecision(1) << result.fit_seconds << " s: " << proportions.str();
}

}  // namespace

BodyFitJob::BodyFitJob(const ServerConfig& config, const BodyModel& model, const Rig& rig,
                       std::shared_ptr<const BodyModel> fit_model, double fps,
                       RecordingControl& recording)
    : config_(config),
      model_(model),
      rig_(rig),
      fit_model_(std::move(fit_model)),
      fps_(fps),
      recording_(recording),
      applied_body_{std::make_shared<const BodyModel>(model), 0} {}

BodyFitJob::~BodyFitJob() {
  if (fit_thread_.joinable()) fit_thread_.join();
}

TrackedBody BodyFitJob::appliedBody() const {
  std::lock_guard lock(body_mutex_);
  return applied_body_;
}

void BodyFitJob::request(int frame_sets, bool apply,
                         std::function<void(const FitBodyResult&)> done) {
  const BodyModel& model = fitModel();
  if (!model.fit_pose) {
    done(fitFailure(BodyFitError::kCannotFit,
                    "the body model '" + model.name +
                        "' has no fit_pose (the pose a subject stands in while the body is "
                        "fitted)"));
    return;
  }
  if (!canAcquire(model)) {
    done(fitFailure(BodyFitError::kCannotFit, whyCannotAcquire(model)));
    return;
  }
  if (apply && config_.replay()) {
    done(fitFailure(BodyFitError::kCannotApply,
                    "apply: a replay tracks the session's body (its poses depend on the recording "
                    "alone); fit without apply"));
    return;
  }
  auto collection = std::make_unique<Collection>();
  collection->frame_sets = std::max(frame_sets, 1);
  collection->apply = apply;
  collection->every = std::max(1, static_cast<int>(std::lround(kFitSetIntervalSeconds * fps_)));
  collection->done = std::move(done);
  collection->last_progress_ns = monotonicNowNs();
  FitBodyResult refusal;
  {
    std::lock_guard lock(mutex_);
    if (!accepting_) {
      refusal = fitFailure(BodyFitError::kStopped, "the pipeline is not running");
    } else if (busy_) {
      refusal =
          fitFailure(BodyFitError::kBusy, "a body fit is already under way; wait for its answer");
    } else if (apply && !recording_.reserveBodyChange()) {
      refusal = fitFailure(BodyFitError::kCannotApply,
                           "apply: a recording is open, and a session stores one body; stop it "
                           "first, or fit without apply");
    } else {
      busy_ = true;
      request_ = std::move(collection);
      return;
    }
  }
  collection->done(refusal);
}

void BodyFitJob::open() {
  std::lock_guard lock(mutex_);
  accepting_ = true;
}

void BodyFitJob::poll() {
  if (!collecting_) {
    std::lock_guard lock(mutex_);
    collecting_ = std::move(request_);
  }
  // Also checked without frames, so a fit on stalled cameras ends.
  if (collecting_ && collect(*collecting_, nullptr)) collecting_.reset();
}

void BodyFitJob::add(const std::vector<SilhouetteMask>& masks, bool complete) {
  if (collecting_ && collect(*collecting_, complete ? &masks : nullptr)) collecting_.reset();
}

void BodyFitJob::close() {
  std::unique_ptr<Collection> pending;
  {
    std::lock_guard lock(mutex_);
    accepting_ = false;
    pending = std::move(request_);
  }
  if (!collecting_) collecting_ = std::move(pending);
  if (!collecting_) return;
  const Collection& fit = *collecting_;
  end(fit.done,
      fitFailure(BodyFitError::kStopped, "the pipeline stopped after " +
                                             std::to_string(fit.frames.size()) + " of " +
                                             std::to_string(fit.frame_sets) + " frame sets"),
      fit.apply);
  collecting_.reset();
}

void BodyFitJob::stop() {
  // The mask thread, which starts fits, has ended: a fit under way is the last; it stops at its
  // next frame set's search (well under a second).
  stop_fit_ = true;
  if (fit_thread_.joinable()) fit_thread_.join();
}

bool BodyFitJob::collect(Collection& collection, const std::vector<SilhouetteMask>* masks) {
  const int64_t now = monotonicNowNs();
  if (masks) {
    // Sets spaced out, so a subject turning in the fit pose is seen from several sides.
    if (collection.seen++ % collection.every == 0) collection.frames.push_back(*masks);
    collection.last_progress_ns = now;
  }
  if (static_cast<int>(collection.frames.size()) >= collection.frame_sets) {
    // The fit before this one ended its request before this could be made: it is finishing.
    if (fit_thread_.joinable()) fit_thread_.join();
    fit_thread_ = std::thread([this, collected = std::move(collection)]() mutable {
      nameThisThread("mocapd-fit");
      run(std::move(collected));
    });
    return true;
  }
  if (now - collection.last_progress_ns < kFitStallNs) return false;
  end(collection.done,
      fitFailure(BodyFitError::kStalled,
                 "no frame set with every camera's silhouettes for " +
                     std::to_string(kFitStallNs / 1'000'000'000) +
                     " s (a stalled camera, or one still waiting for a background); " +
                     "frame sets collected: " + std::to_string(collection.frames.size()) + " of " +
                     std::to_string(collection.frame_sets)),
      collection.apply);
  return true;
}

void BodyFitJob::run(Collection collection) {
  FitBodyResult result;
  result.frame_sets_used = static_cast<int>(collection.frames.size());
  const int64_t start = monotonicNowNs();
  try {
    const BodyModel& model = fitModel();
    std::string why_not;
    BodyFitOptions options;
    options.should_stop = [this] { return stop_fit_.load(); };
    const std::optional<BodyFit> fit = fitBodyInPose(
        model, rig_, collection.frames, config_.tracker.filter.likelihood, options, &why_not);
    if (fit) {
      // The sets the subject was found in (fitBodyInPose leaves the others out).
      result.frame_sets_used = static_cast<int>(fit->poses.size());
      result.fit = *fit;
      result.body = proportionedBodyModel(model, fit->proportions);
      if (collection.apply) result.body_version = apply(fit->proportions);
    } else {
      result.error = BodyFitError::kNoSubject;
      result.message = "no subject found standing in the fit pose: " + why_not;
    }
  } catch (const BodyFitStopped&) {
    result.error = BodyFitError::kStopped;
    result.message = "the pipeline stopped during the body fit";
  } catch (const std::exception& error) {
    result.error = BodyFitError::kFailed;
    result.message = std::string("the body fit failed: ") + error.what();
  }
  result.fit_seconds = static_cast<double>(monotonicNowNs() - start) / 1e9;
  if (result.error == BodyFitError::kNone) logFit(result);
  end(collection.done, result, collection.apply);
}

uint32_t BodyFitJob::apply(const BodyProportions& proportions) {
  // On the tracked body as configured (gait's frozen DOFs stay frozen), so fits do not compound.
  auto applied = std::make_shared<const BodyModel>(proportionedBodyModel(model_, proportions));
  std::lock_guard lock(body_mutex_);
  applied_body_ = {std::move(applied), applied_body_.version + 1};
  body_switch_pending_ = true;
  return applied_body_.version;
}

void BodyFitJob::end(const std::function<void(const FitBodyResult&)>& done,
                     const FitBodyResult& result, bool applies) {
  {
    std::lock_guard lock(mutex_);
    if (applies) recording_.releaseBodyChange();
    busy_ = false;
  }
  done(result);
}

}  // namespace mocap
