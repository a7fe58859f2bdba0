// Animation: the seed's Animation.cpp, a simple face for a terminal. config/Animation.ini
// (read here with ini_read, ini_file.hpp, as the seed reads its Animation.ini itself) describes a head
// (fixed-width text lines) and features drawn over it (brows, eyes, mouth, beacon), each
// an ordered list of versions (equal-length text strips), plus the emotion matrix: which
// emotion input picks each feature's target version and over what input range. Every
// update() computes the targets from the planner's emotion and moves each feature ONE
// version toward its target (the seed's ramp); the beacon steps one version per update
// while the micro is active and stands still otherwise. Nothing here blocks or prints:
// the robot hands lines() to the console.
#pragma once

#include <string>
#include <vector>

#include "navkit/ini.hpp"

extern "C" {
#include "navkit/navkit_proto.h"
}

namespace navkit {

// What chooses a feature's target version.
enum class FaceInput {
    happiness, // emotion.happiness (-100..100)
    arousal,   // emotion.arousal (0..100)
    surprise,  // emotion.surprise (0..100)
    beacon,    // none: one version further (wrapping) per update while the micro is active
};

// One feature: its place, versions, emotion-matrix row and current state.
struct FaceFeature {
    std::string name; // its [section] in Animation.ini
    int row = 0;      // head line the versions are drawn on (0 = top)
    int col = 0;      // column of a version's first character
    FaceInput input = FaceInput::happiness;
    int from = 0;                      // input value (emotion units) that targets version 0
    int to = 0;                        // input value that targets the last version
    std::vector<std::string> versions; // equal-length strips; ' ' is transparent
    std::string talk;                  // strip shown every other update while talking; "" = none
    int gaze_cols = 0;                 // columns moved at gaze_x = +-100 (+ = right)
    int gaze_rows = 0;                 // rows moved at gaze_y = +-100 (+ = up)
    // state
    int version = 0;        // current version index (ramps one step per update)
    int target = 0;         // version index the emotion asks for
    int dx = 0;             // current gaze offset, columns (+ = right)
    int dy = 0;             // current gaze offset, rows (+ = down)
    bool talk_open = false; // this update shows `talk` instead of the version
};

// What one update() did.
struct FaceUpdate {
    bool changed = false;    // lines() differ from the previous update's (always true on the first)
    bool rejected = false;   // a new emotion (time_tag not refused before) failed the spec's
                             // range check; the last valid emotion is kept
    int rejected_field = -1; // NAVKIT_EMOTION_FIELD_* of its first bad field, when rejected
};

class Animation {
public:
    // Load and validate an Animation.ini (path as given); every feature starts at version 0
    // with no gaze offset (the seed: all indexes zero, drawn on the first update). Throws
    // ConfigError "file:line: key: reason" for a missing file, an unknown section or key,
    // a duplicate, a malformed or out-of-range value, or a missing required key.
    void start(const std::string &path);
    // One frame: targets from the emotion (ranges per the spec; a message outside them is
    // refused), one ramp step per feature and gaze axis, the beacon stepped when
    // micro_active (micro online), talking features toggled. Never blocks.
    FaceUpdate update(const navkit_emotion_t &emotion, bool micro_active);
    // Drop the face (the seed's End(): deletes the bitmaps); start() may be called again.
    void end();

    bool started() const { return !head_.empty(); }
    // The face as drawn now: the head's lines with every feature over it (width() chars each).
    const std::vector<std::string> &lines() const { return lines_; }
    int width() const { return width_; }
    const std::vector<FaceFeature> &features() const { return features_; }
    // One line for logs: "name=version" per feature in drawing order, ":talk" while a
    // talking feature shows its talk strip, "@dx,dy" for features that follow the gaze.
    std::string state() const;

private:
    void render();

    int width_ = 0;                     // characters per face line
    std::vector<std::string> head_;     // background lines, drawn first
    std::vector<FaceFeature> features_; // in drawing order
    std::vector<std::string> lines_;    // the last render
    navkit_emotion_t good_{};           // the last emotion that passed the range check
    bool refused_any_ = false;          // some emotion was refused (refused_tag_ valid)
    int32_t refused_tag_ = 0;           // time_tag of the last refused emotion (said once)
    bool drawn_ = false;                // update() has rendered at least once
};

} // namespace navkit
