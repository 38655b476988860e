#pragma once
// WAV data files through libsndfile.

#include <filesystem>
#include <string>
#include <vector>

#include "dsp/record.h"

namespace panelbass::dsp {

/// Sample format of a written WAV file.
enum class WavFormat { pcm16, pcm24, float32 };

/// Reads channels of a WAV file (16/24/32-bit PCM or float) as a record with the file's sample rate.
/// Each entry of `channels` is a zero-based channel index ("0", "1", …) or a channel name; names are
/// those panelbass stores in the file's comment tag ("panelbass-channels: u,y,i,x"). PCM is scaled to
/// [-1, 1). Throws DataError naming the file and the channel for an unreadable file, a missing channel,
/// a non-finite sample, or fewer than `min_samples` frames.
Record read_wav(const std::filesystem::path& path, const std::vector<std::string>& channels,
                std::size_t min_samples = 1);

/// Writes every column of `record` as one channel, at `record.fs` (must be > 0), storing the column
/// names in the comment tag. PCM formats require every value within [-1, 1]: a value outside is an
/// error naming the column and the sample, never silently clipped.
void write_wav(const std::filesystem::path& path, const Record& record, WavFormat format);

}  // namespace panelbass::dsp
