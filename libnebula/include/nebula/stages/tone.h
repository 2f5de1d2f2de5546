// SPDX-License-Identifier: Apache-2.0
#pragma once
/// @file tone.h
/// nebtone's stage: display frames of an EXR sequence with one tone curve that changes
/// slowly over time (DESIGN §8), so that a fly-through does not flicker as the automatic
/// per-frame curve of each PNG would.

#include "nebula/core/run.h"
#include "nebula/io/image.h"

#include <string>
#include <vector>

namespace nebula {

/// nebtone's settings.
struct ToneSequenceOptions
{
    std::string input;        ///< EXR names with a frame pattern (f.####.exr)
    std::string output;       ///< PNG names with a frame pattern
    std::vector<long> frames; ///< frames to tone; empty: every frame of the pattern on disk
    /// Smoothing window [s]: each frame's curve comes from the luminance statistics of the
    /// frames around it, Gaussian weights of standard deviation window / 2 (truncated at 3
    /// standard deviations); 0: each frame its own curve.
    double window = 1.0;
    bool whole = false; ///< one curve for the whole sequence (window "all")
    /// How far a smoothed frame's white point may move from the sequence's, in stops (factors
    /// of 2) each way; with smoothing (a window, not 0) the automatic gamma is also one for the
    /// sequence. A dark interior stays dark instead of being lifted into flat haze.
    double adaptStops = 2.0;
    double fps = 0.0; ///< frames per second; 0: the EXRs' nebula:frame, else 24
    int bits = 8;     ///< PNG bit depth, 8 or 16
    /// The tone, with nebrender's options and meanings (cli::addTone()): automatic (white
    /// point: tone.percentile of the lit pixels' luminance, smoothed over the window; gamma
    /// fitted to the smoothed log-mean), with a fixed gamma (fixedGamma: --gamma alone), or
    /// a fixed curve for every frame (!automatic: --exposure, with --gamma).
    ToneParams tone;
    bool skipExisting = false;
};

/// The curve of every frame from the frames' statistics @p stats at times @p times [s]: the
/// logarithms of white and log-mean luminance averaged with Gaussian weights of standard
/// deviation window / 2 over the lit frames within 3 standard deviations (all frames if
/// @p whole), then toneCurveFromStats(). With smoothing (@p whole or window > 0) the
/// sequence's curve (all its lit frames averaged) gives every frame its gamma, and each
/// frame's white point stays within @p adaptStops stops of the sequence's. Window 0: each
/// frame its own curve, as nebrender's. Frames with the same statistics get the same curve;
/// a constant sequence a constant curve.
std::vector<ToneCurve> sequenceToneCurves(const std::vector<double>& times,
                                          const std::vector<LuminanceStats>& stats, double window,
                                          bool whole, double adaptStops = 2.0);

/// The frames of @p pattern that exist (files whose names match it), in order. Throws
/// UsageError if @p pattern has no frame pattern or it is in a folder name.
std::vector<long> framesOnDisk(const std::string& pattern);

/// The fps a frame's nebula:frame attribute (JSON, @p text) records, 0 if none. Throws Error
/// naming @p where for text that is not bounded JSON (checkJsonBounds()) or an fps outside
/// [0.001, 10000].
double frameAttributeFps(const std::string& text, const std::string& where);

/// The white point a frame's nebula:luminance attribute (JSON, @p text) records at
/// @p percentile (and with the star sprites' pixels counted as @p stars says, where it records
/// that), or -1 if it was taken at another percentile or otherwise. Throws Error naming @p where
/// for text that is not bounded JSON, lacks a numeric "white" or "percentile", or whose white point
/// is negative or not finite.
double luminanceAttributeWhite(const std::string& text, double percentile, const std::string& where,
                               bool stars = false);

/// nebtone: reads every frame whole and its statistics from its pixels before it writes any
/// PNG (a damaged or missing frame fails the run with no PNG written; a frame's
/// nebula:luminance that disagrees with its pixels is a warning), leaves a frame whose white
/// point is a million-fold from the sequence's median out of the smoothing (a warning),
/// computes the curves (sequenceToneCurves()) and writes each PNG atomically. Output names
/// must end in .png; --skip-existing skips a frame whose PNG decodes whole (pngReadsBack()).
void toneSequence(const ToneSequenceOptions& opts, const Run& run);

} // namespace nebula
