// tools/plot.h — `manyrods plot` (docs/scenes.md "Plots"): PNGs and a GIF of
// an output file, drawn by gnuplot.
#pragma once

#include <string>

namespace manyrods::cli {

// Plots the output file (or a chunked sweep's index) `in` into `dir`
// (empty: <in without extension>_plots): tips, energy, rod shapes and their
// animation, and for a sweep its summary plots. Returns the exit status: 0,
// 1 gnuplot failed, 2 a directory that cannot be written. Throws
// h5::H5Error for a file that is not a manyrods output.
int plot(const std::string& in, std::string dir);

}  // namespace manyrods::cli
