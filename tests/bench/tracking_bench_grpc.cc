// gRPC loopback throughput of TrackingService (see tracking_bench_grpc.h).
#include "tests/bench/tracking_bench_grpc.h"

#include <grpcpp/grpcpp.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdio>
#include <ctime>
#include <mutex>
#include <thread>

#include "common/timing.h"
#include "server/tracking_service.h"

namespace texfree::bench {
namespace {

using Clock = std::chrono::steady_clock;

// CPU time of the whole process (server and client threads), milliseconds.
double ProcessCpuMs() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return ts.tv_sec * 1e3 + ts.tv_nsec * 1e-6;
}

double Median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

double Quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(q * (v.size() - 1) + 0.5))];
}

struct StreamResult {
  int sent = 0, results = 0, dropped = 0, tracked = 0;
  int dropped_first_second = 0;  // reported in the stream's first second (start-up)
  double seconds = 0;
  std::vector<double> server_ms, latency_ms;
};

// One stream: `window` > 0 keeps that many frames in flight (as fast as possible);
// otherwise frames go out every 1/fps seconds whatever comes back.
StreamResult RunStream(v1::TrackingService::Stub& stub, const std::vector<std::string>& jpegs,
                       int window, double fps, double seconds) {
  StreamResult out;
  grpc::ClientContext context;
  auto stream = stub.Track(&context);
  v1::TrackRequest config;
  config.mutable_config()->mutable_options()->set_track_documents(true);
  stream->Write(config);
  std::mutex mutex;
  std::condition_variable cv;
  int in_flight = 0;
  bool done = false;
  const auto t0 = Clock::now();
  std::thread sender([&] {
    for (int i = 0;; ++i) {
      const auto due = t0 + std::chrono::duration_cast<Clock::duration>(
                                std::chrono::duration<double>(fps > 0 ? i / fps : 0));
      if (Clock::now() - t0 > std::chrono::duration<double>(seconds)) break;
      if (window > 0) {
        std::unique_lock lock(mutex);
        cv.wait(lock, [&] { return in_flight < window || done; });
        if (done) break;
      } else {
        std::this_thread::sleep_until(due);
      }
      v1::TrackRequest r;
      r.mutable_frame()->set_frame_index(i);
      r.mutable_frame()->mutable_image()->set_encoded(jpegs[i % jpegs.size()]);
      {
        std::lock_guard lock(mutex);
        ++in_flight;
        ++out.sent;
      }
      if (!stream->Write(r)) break;
    }
    stream->WritesDone();
  });
  v1::TrackResponse response;
  while (stream->Read(&response)) {
    {
      std::lock_guard lock(mutex);
      in_flight -= 1 + static_cast<int>(response.dropped_frames());
    }
    cv.notify_all();
    ++out.results;
    out.dropped += static_cast<int>(response.dropped_frames());
    if (Clock::now() - t0 < std::chrono::seconds(1))
      out.dropped_first_second += static_cast<int>(response.dropped_frames());
    for (const auto& t : response.targets())
      if (t.state() != v1::TrackedTarget::LOST) {
        ++out.tracked;
        break;
      }
    out.server_ms.push_back(response.server_ms());
    out.latency_ms.push_back(response.latency_ms());
  }
  {
    std::lock_guard lock(mutex);
    done = true;
  }
  cv.notify_all();
  sender.join();
  stream->Finish();
  out.seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  return out;
}

}  // namespace

void RunGrpcThroughput(const server::DocumentRegistry* registry,
                       const std::vector<std::string>& jpegs, const std::string& sequence,
                       int streams, double fps, double seconds,
                       const server::TrackingServiceOptions& options) {
  server::TrackingServiceImpl service(registry, options);
  grpc::ServerBuilder builder;
  int port = 0;
  builder.AddListeningPort("127.0.0.1:0", grpc::InsecureServerCredentials(), &port);
  builder.RegisterService(&service);
  builder.SetMaxReceiveMessageSize(64 << 20);
  auto server = builder.BuildAndStart();
  auto channel_for = [&] {
    grpc::ChannelArguments args;
    args.SetInt("grpc.use_local_subchannel_pool", 1);  // one connection per stream
    return grpc::CreateCustomChannel("127.0.0.1:" + std::to_string(port),
                                     grpc::InsecureChannelCredentials(), args);
  };
  std::printf("\n### gRPC loopback throughput (%u cores, JPEG 640x480 frames of %s)\n\n",
              std::thread::hardware_concurrency(), sequence.c_str());
  std::printf("| test | streams | frames answered | fps per stream | dropped (in the first s) | "
              "tracked | median server ms | median latency ms | p99 latency ms | CPU ms per "
              "frame |\n"
              "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
  {
    auto stub = v1::TrackingService::NewStub(channel_for());
    const double cpu0 = ProcessCpuMs();
    const StreamResult r = RunStream(*stub, jpegs, 2, 0, seconds);
    const double cpu = ProcessCpuMs() - cpu0;
    std::printf(
        "| 1 stream, 2 frames in flight | 1 | %d | %.1f | %d (%d) | %.0f%% | %.2f | %.1f | %.1f | "
        "%.2f |\n",
        r.results, r.results / r.seconds, r.dropped, r.dropped_first_second,
        100.0 * r.tracked / std::max(1, r.results), Median(r.server_ms), Median(r.latency_ms),
        Quantile(r.latency_ms, 0.99), cpu / std::max(1, r.results));
    std::fflush(stdout);
  }
  {
    std::vector<StreamResult> results(streams);
    std::vector<std::thread> threads;
    const double cpu0 = ProcessCpuMs();
    const auto wall0 = Clock::now();
    for (int s = 0; s < streams; ++s) {
      threads.emplace_back([&, s] {
        auto stub = v1::TrackingService::NewStub(channel_for());
        results[s] = RunStream(*stub, jpegs, 0, fps, seconds);
      });
    }
    for (auto& t : threads) t.join();
    const double cpu = ProcessCpuMs() - cpu0;
    const double wall_seconds = std::chrono::duration<double>(Clock::now() - wall0).count();
    int answered = 0, dropped = 0, dropped_first_second = 0, tracked = 0, sent = 0;
    int fewest = 1 << 30, most = 0;  // answered per stream: the cores are shared fairly?
    double rate = 0;
    std::vector<double> server_ms, latency;
    for (const auto& r : results) {
      answered += r.results;
      dropped += r.dropped;
      dropped_first_second += r.dropped_first_second;
      fewest = std::min(fewest, r.results);
      most = std::max(most, r.results);
      tracked += r.tracked;
      sent += r.sent;
      rate += r.results / r.seconds;
      server_ms.insert(server_ms.end(), r.server_ms.begin(), r.server_ms.end());
      latency.insert(latency.end(), r.latency_ms.begin(), r.latency_ms.end());
    }
    std::printf(
        "| %d streams at %.0f fps | %d | %d of %d | %.1f | %d (%d) | %.0f%% | %.2f | %.1f | %.1f | "
        "%.2f |\n",
        streams, fps, streams, answered, sent, rate / std::max(1, streams), dropped,
        dropped_first_second, 100.0 * tracked / std::max(1, answered), Median(server_ms),
        Median(latency), Quantile(latency, 0.99), cpu / std::max(1, answered));
    std::printf("\nCPU time counts server and client threads; %d streams at %.0f fps need %.0f "
                "frames/s x CPU ms per frame of the %u cores' %u ms per second. The process "
                "got %.2f cores (CPU time / wall time) and needed %.2f: fewer means the "
                "machine's other load took the rest.\n",
                streams, fps, streams * fps, std::thread::hardware_concurrency(),
                1000 * std::thread::hardware_concurrency(), cpu / 1000 / wall_seconds,
                streams * fps * cpu / std::max(1, answered) / 1000);
    std::printf("Frames answered per stream: %d to %d.\n", fewest, most);
  }
  server->Shutdown(std::chrono::system_clock::now() + std::chrono::seconds(2));
}

}  // namespace texfree::bench
