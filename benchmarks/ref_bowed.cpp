// Reference for the bowed row of benchmarks/run_all.py: STK's own Bowed instrument, as shipped
// (libstk-dev), played the way its documentation shows: set the sample rate, noteOn, tick the
// instrument into a frame buffer, write the buffer with STK's FileWvOut (32-bit float WAV).
//
// usage: ref_bowed SAMPLES RATE FREQUENCY OUT.wav    (prints loop_seconds: the tick loop alone,
// into a prefaulted buffer, std::chrono::steady_clock)
// Build: g++ -O3 -march=native ref_bowed.cpp -o ref_bowed -lstk
#include <stk/Bowed.h>
#include <stk/FileWvOut.h>
#include <stk/Stk.h>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>

int main(int argc, char **argv) {
  if (argc != 5) { std::fprintf(stderr, "usage: ref_bowed SAMPLES RATE FREQUENCY OUT.wav\n"); return 2; }
  const long n = std::atol(argv[1]);
  const double rate = std::atof(argv[2]), frequency = std::atof(argv[3]);
  stk::Stk::setSampleRate(rate);
  stk::StkFrames frames(n, 1);
  for (long i = 0; i < n; i++) frames[i] = 0.0;     // prefault
  stk::Bowed bowed(50.0);
  bowed.noteOn(frequency, 0.8);
  const auto t0 = std::chrono::steady_clock::now();
  for (long i = 0; i < n; i++) frames[i] = bowed.tick();
  const auto t1 = std::chrono::steady_clock::now();
  stk::FileWvOut wav(argv[4], 1, stk::FileWrite::FILE_WAV, stk::Stk::STK_FLOAT32);
  wav.tick(frames);
  wav.closeFile();
  double sq = 0.0;
  for (long i = 0; i < n; i++) sq += frames[i] * frames[i];
  std::printf("loop_seconds %.9f\nrms %.6g\n", std::chrono::duration<double>(t1 - t0).count(), std::sqrt(sq / n));
  return 0;
}
