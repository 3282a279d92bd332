// Dynamic batching, the service half: which unary Evaluate calls may share a launch, and the
// scheduler's batch job that runs them (server/scheduler.h gathers, server/batch_eval.h
// evaluates and scatters). Each member is validated, answered and logged on its own, as
// RunBatch would; only the device launch is shared.
#include <algorithm>
#include <sstream>

#include "server/batch_eval.h"
#include "server/eval_plan.h"
#include "server/service.h"

namespace glint {
namespace {

using Clock = std::chrono::steady_clock;

double MsSince(Clock::time_point t) {
  return std::chrono::duration<double, std::milli>(Clock::now() - t).count();
}

}  // namespace

std::shared_ptr<Scheduler::BatchMember> GlintServiceImpl::MakeEvaluateMember(
    grpc::CallbackServerContext *ctx, const glint::v1::EvaluateRequest *request,
    glint::v1::EvaluateResponse *response, Clock::time_point received,
    std::function<void(const Status &)> finish) const {
  const uint32_t max_queries = scheduler_->batching().max_queries;
  if (!max_queries || !Batchable(*request, max_queries)) return nullptr;
  auto member = std::make_shared<EvaluateMember>();
  member->key = BatchKey(*request);
  member->queries = request->queries().count();
  member->ctx = ctx;
  member->request = request;
  member->response = response;
  member->received = received;
  member->finish = std::move(finish);
  return member;
}

std::vector<Scheduler::Respond> GlintServiceImpl::RunEvaluateBatch(
    int worker, const Scheduler::Members &members) {
  const auto start = Clock::now();
  const size_t n = members.size();
  std::vector<EvaluateMember *> m(n);
  std::vector<Status> status(n);
  std::vector<double> queue_ms(n);
  std::vector<BatchPart> parts;
  std::vector<size_t> part_of;  // member index of each part
  const glint::v1::EvaluateRequest *first = nullptr;
  for (size_t i = 0; i < n; ++i) {
    // Only MakeEvaluateMember's members are ever submitted with a member.
    m[i] = static_cast<EvaluateMember *>(members[i].get());
    queue_ms[i] = MsSince(m[i]->received);
    if (options_.metrics) options_.metrics->ObserveQueueWait(queue_ms[i] / 1e3);
    const glint::v1::EvaluateRequest &r = *m[i]->request;
    status[i] = ValidateQueries(r.queries(), r.lights_size() > 0, options_.limits, 0, false);
    if (status[i].ok()) status[i] = ValidateQueriesForModel(r.queries(), r, 0);
    if (!status[i].ok()) continue;
    if (!first) first = &r;
    glint::v1::EvaluateResponse *res = m[i]->response;
    res->set_count(r.queries().count());
    res->mutable_radiance()->Resize(int(r.queries().count()) * 3, 0.0f);
    grpc::CallbackServerContext *ctx = m[i]->ctx;
    parts.push_back({&r.queries(), res->mutable_radiance()->mutable_data(),
                     [this, ctx] { return StopReason(ctx); }, Status::Ok()});
    part_of.push_back(i);
  }
  std::string kernel = "-";
  BatchStats stats;
  double compile_ms = 0;
  if (first) {
    // Equal keys: every member's plan equals the first's (batch_eval.h).
    EvalPlan plan = MakeEvalPlan(*first, first->queries());
    Status table = ResolveRequestTable(first->material(), &plan);
    // A cold variant is built first and timed apart (EvaluateStats.compile_ms), as in
    // RunBatchInto; on the first member's queries, which were validated above.
    if (table.ok() && engine_)
      table = engine_->Prepare(worker, plan, QueryView::Of(*parts.front().queries), &compile_ms);
    if (table.ok()) {
      kernel = plan.spec.Describe();
      SliceOptions slicing;
      // The dearest query of any member bounds a slice (each member was admitted by the same
      // per-query cost in Evaluate's handler).
      slicing.per_query_cost = BatchPerQueryCost(*first, parts);
      slicing.target_ms = options_.slice_ms;
      StopSlicesFor(nullptr, &slicing);  // the server's reason; each part has its own
      EvaluateBatched(engine_, worker, plan, &parts, slicing, &stats);
    }
    for (size_t k = 0; k < parts.size(); ++k)
      status[part_of[k]] = table.ok() ? parts[k].status : table;
  }
  // The members' validation above and the launch: as unary Evaluate's compute_ms, without the
  // build of a cold variant.
  const double compute_ms = MsSince(start) - compile_ms;
  if (options_.metrics && compile_ms > 0 && first)
    options_.metrics->ObserveCompile(glint::v1::Model_IsValid(first->material().model())
                                         ? glint::v1::Model_Name(first->material().model())
                                         : "?",
                                     compile_ms / 1e3);
  std::vector<Scheduler::Respond> responds(n);
  for (size_t i = 0; i < n; ++i) {
    const glint::v1::EvaluateRequest &r = *m[i]->request;
    glint::v1::EvaluateResponse *res = m[i]->response;
    const uint32_t count = r.queries().count();
    if (status[i].ok()) {
      res->mutable_stats()->set_queue_ms(queue_ms[i]);
      res->mutable_stats()->set_compute_ms(compute_ms);
      res->mutable_stats()->set_compile_ms(compile_ms);
      res->mutable_stats()->set_device(DeviceName());
      res->mutable_stats()->set_batch_requests(uint32_t(stats.evaluated_parts));
      if (options_.metrics) {
        const char *model = glint::v1::Model_IsValid(r.material().model())
                                ? glint::v1::Model_Name(r.material().model()).c_str()
                                : "?";
        // The launch's time shared by query count, so the model's total stays the device time.
        options_.metrics->CountEvaluated(
            model, count, compute_ms / 1e3 * double(count) / std::max(1.0, double(stats.queries)));
      }
    } else {
      res->Clear();
    }
    std::ostringstream line;
    line << "Evaluate n=" << count << " kernel=" << kernel << " queue_ms=" << queue_ms[i]
         << " compile_ms=" << compile_ms << " compute_ms=" << compute_ms
         << " batch=" << stats.evaluated_parts << "/" << stats.queries
         << (status[i].ok() ? " ok" : " refused: " + status[i].message());
    LogLine(line.str());
    responds[i] = [finish = m[i]->finish, st = status[i]] { finish(st); };
  }
  return responds;
}

}  // namespace glint
