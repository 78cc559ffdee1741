// `mpirun -np N shrefract bake ...`: rank r bakes shard r/N (shard.h) with its own threads; the
// parts travel to rank 0 as part-file bytes and rank 0 runs the same merge as `shrefract merge`,
// so the field is the one the single-process bake writes. MPI calls come from the main thread
// only (the bake calls its progress callback there): MPI_THREAD_FUNNELED is enough.
#include <mpi.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "cli/progress.h"
#include "cli/shard_commands.h"

namespace shrefract::cli {
namespace {

constexpr int kProgressTag = 1;  // 4 x uint64: done, total, rays, final (0 or 1)
constexpr int kPartTag = 2;      // uint64 size, then the part's bytes in chunks
constexpr uint64_t kChunk = uint64_t(1) << 30;  // MPI counts are int

[[noreturn]] void abortJob(int rank, int ranks, const std::string& message) {
  std::fprintf(stderr, "shrefract bake: rank %d of %d: %s\n", rank, ranks, message.c_str());
  std::fflush(stderr);
  MPI_Abort(MPI_COMM_WORLD, 1);
  std::abort();  // MPI_Abort does not return
}

using Message = std::array<uint64_t, 4>;

// Rank 0 draws the progress of every rank from their messages; the others send theirs, at most
// every 0.25 s, without waiting for rank 0.
class RankProgress {
 public:
  RankProgress(int rank, int ranks) : rank_(rank), ranks_(ranks), state_(size_t(ranks)), final_(size_t(ranks)) {}

  void update(const bake::BakeProgress& p) {
    own_ = {p.samplesDone, p.samplesTotal, p.rays, 0};
    if (rank_ == 0) {
      drain(false);
      draw();
      return;
    }
    const auto now = std::chrono::steady_clock::now();
    if (now - lastSend_ < std::chrono::milliseconds(250)) return;
    int idle = 1;
    if (pending_) MPI_Test(&request_, &idle, MPI_STATUS_IGNORE);
    if (!idle) return;
    sending_ = own_;
    MPI_Isend(sending_.data(), 4, MPI_UINT64_T, 0, kProgressTag, MPI_COMM_WORLD, &request_);
    pending_ = true;
    lastSend_ = now;
  }

  // After the rank's bake: the others send their final count, rank 0 waits for every rank's.
  void finish() {
    if (rank_ != 0) {
      if (pending_) MPI_Wait(&request_, MPI_STATUS_IGNORE);
      Message last = own_;
      last[3] = 1;
      MPI_Send(last.data(), 4, MPI_UINT64_T, 0, kProgressTag, MPI_COMM_WORLD);
      return;
    }
    final_[0] = true;
    drain(true);
    draw();
    bar_.finish();
  }

 private:
  void receive(int source) {
    Message m{};
    MPI_Recv(m.data(), 4, MPI_UINT64_T, source, kProgressTag, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
    state_[size_t(source)] = m;
    if (m[3]) final_[size_t(source)] = true;
  }
  void drain(bool untilFinal) {
    for (;;) {
      int flag = 0;
      MPI_Status status;
      MPI_Iprobe(MPI_ANY_SOURCE, kProgressTag, MPI_COMM_WORLD, &flag, &status);
      if (flag) {
        receive(status.MPI_SOURCE);
        continue;
      }
      if (!untilFinal || std::all_of(final_.begin(), final_.end(), [](bool f) { return f; })) return;
      MPI_Probe(MPI_ANY_SOURCE, kProgressTag, MPI_COMM_WORLD, &status);
      receive(status.MPI_SOURCE);
      draw();
    }
  }
  void draw() {
    uint64_t done = own_[0], total = own_[1], rays = own_[2];
    for (int r = 1; r < ranks_; ++r) {
      const Message& m = state_[size_t(r)];
      done += m[0];
      total += m[1] ? m[1] : own_[1];  // not heard from yet: about rank 0's share
      rays += m[2];
    }
    // Its own clock: rank 0 keeps drawing while it waits for the others after its own share.
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
    bar_.update(done, total, seconds, seconds > 0.0 ? double(rays) / seconds : 0.0, "rays/s");
  }

  int rank_, ranks_;
  std::vector<Message> state_;
  std::vector<bool> final_;
  Message own_{}, sending_{};
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
  MPI_Request request_ = MPI_REQUEST_NULL;
  bool pending_ = false;
  std::chrono::steady_clock::time_point lastSend_{};
  Progress bar_{"bake", stderr};
};

void sendBytes(const std::vector<uint8_t>& bytes) {
  uint64_t size = bytes.size();
  MPI_Send(&size, 1, MPI_UINT64_T, 0, kPartTag, MPI_COMM_WORLD);
  for (uint64_t at = 0; at < size; at += kChunk)
    MPI_Send(bytes.data() + at, static_cast<int>(std::min(kChunk, size - at)), MPI_BYTE, 0, kPartTag, MPI_COMM_WORLD);
}

std::vector<uint8_t> receiveBytes(int source) {
  uint64_t size = 0;
  MPI_Recv(&size, 1, MPI_UINT64_T, source, kPartTag, MPI_COMM_WORLD, MPI_STATUS_IGNORE);
  std::vector<uint8_t> bytes(size);
  for (uint64_t at = 0; at < size; at += kChunk)
    MPI_Recv(bytes.data() + at, static_cast<int>(std::min(kChunk, size - at)), MPI_BYTE, source, kPartTag,
             MPI_COMM_WORLD, MPI_STATUS_IGNORE);
  return bytes;
}

}  // namespace

int distributedBake(const bake::Scene& scene, bake::BakeOptions options, const std::string& output, bool json) {
  int provided = 0, rank = 0, ranks = 1;
  MPI_Init_thread(nullptr, nullptr, MPI_THREAD_FUNNELED, &provided);
  MPI_Comm_rank(MPI_COMM_WORLD, &rank);
  MPI_Comm_size(MPI_COMM_WORLD, &ranks);
  if (provided < MPI_THREAD_FUNNELED) abortJob(rank, ranks, "the MPI library does not support MPI_THREAD_FUNNELED");
  if (rank != 0) options.note = nullptr;  // the choices are the same on every rank: rank 0 says them
  RankProgress progress(rank, ranks);
  options.progress = [&](const bake::BakeProgress& p) { progress.update(p); };
  auto part = bake::bakePart(scene, options, bake::Shard{uint32_t(rank), uint32_t(ranks)});
  if (!part) abortJob(rank, ranks, options.settings.source + ": " + part.error().message);
  progress.finish();
  if (rank != 0) {
    sendBytes(bake::serializePart(part.value()));
    MPI_Finalize();
    return 0;
  }
  std::vector<bake::BakePart> parts;
  parts.push_back(std::move(part.value()));
  parts.front().name = "rank 0";
  for (int r = 1; r < ranks; ++r) {
    const std::vector<uint8_t> bytes = receiveBytes(r);
    auto received = bake::parsePart(bytes.data(), bytes.size(), "rank " + std::to_string(r));
    if (!received) abortJob(rank, ranks, received.error().message);
    parts.push_back(std::move(received.value()));
  }
  auto field = bake::mergeParts(scene, std::move(parts), options.stage, options.note);
  if (!field) abortJob(rank, ranks, field.error().message);  // names the rank at fault
  // The field is written to a temporary file and renamed: an abort leaves no partial output.
  if (const int code = writeFieldAndSummary(field.value(), output, json); code != 0) {
    MPI_Abort(MPI_COMM_WORLD, code);
    return code;
  }
  MPI_Finalize();
  return 0;
}

}  // namespace shrefract::cli
