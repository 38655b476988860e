#pragma once
// Denormals flushed to zero on the audio thread for the duration of a block (JUCE's ScopedNoDenormals): a
// decaying IIR or state-space tail goes subnormal, and subnormal arithmetic is tens of times slower on x86, so a
// quiet program could otherwise overrun its period. The flags are the thread's own and are put back at the end.

#include <cstdint>

#if defined(__SSE2__) || defined(__x86_64__)
#include <immintrin.h>
#endif

namespace panelbass::engine {

/// Sets flush-to-zero and denormals-are-zero on this thread while it lives; restores the previous state.
/// Allocation-free and noexcept; a no-op where the processor has no such mode.
class ScopedFlushDenormals {
 public:
  ScopedFlushDenormals() noexcept {
#if defined(__SSE2__) || defined(__x86_64__)
    saved_ = _mm_getcsr();
    _mm_setcsr(saved_ | kFlushToZero | kDenormalsAreZero);
#elif defined(__aarch64__)
    std::uint64_t fpcr = 0;
    asm volatile("mrs %0, fpcr" : "=r"(fpcr));
    saved_ = fpcr;
    asm volatile("msr fpcr, %0" : : "r"(fpcr | kFlushToZeroArm));
#endif
  }
  ~ScopedFlushDenormals() noexcept {
#if defined(__SSE2__) || defined(__x86_64__)
    _mm_setcsr(static_cast<unsigned>(saved_));
#elif defined(__aarch64__)
    asm volatile("msr fpcr, %0" : : "r"(saved_));
#endif
  }
  ScopedFlushDenormals(const ScopedFlushDenormals&) = delete;
  ScopedFlushDenormals& operator=(const ScopedFlushDenormals&) = delete;

 private:
  static constexpr unsigned kFlushToZero = 0x8000u;       // MXCSR.FTZ
  static constexpr unsigned kDenormalsAreZero = 0x0040u;  // MXCSR.DAZ
  static constexpr std::uint64_t kFlushToZeroArm = 1ull << 24;  // FPCR.FZ
  std::uint64_t saved_ = 0;
};

}  // namespace panelbass::engine
