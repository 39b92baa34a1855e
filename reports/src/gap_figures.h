// gap.html's figures per channel (private to reports/): the plots, built apart from their PNG files
// so that what they show (series, units) is testable.
#pragma once

#include <string>
#include <vector>

#include "hexsim/gap/diagnose.h"
#include "hexsim/render/plot.h"

namespace hexsim::reports {

// Field quantities are shown in mG (1 mG = 0.1 µT), every other in the channel's own unit: the
// factor from the channel's unit to the one shown, and the unit shown.
double GapShownScale(const gap::ChannelResult& c);
std::string GapShownUnit(const gap::ChannelResult& c);

struct GapFigure {
  std::string file;           // gap_<channel>_<kind>.png
  render::Plot2D plot;
  bool phase_legend = false;  // shaded by flight phase: the page prints PhaseLegendHtml() under it
};

// |residual| against time over the flight phases, each axis before and after, and (where the chosen
// effect has one) the residual against its regressor, all in GapShownUnit.
std::vector<GapFigure> GapChannelFigures(const gap::ChannelResult& c, const std::vector<gap::PhaseSpan>& phases);

// The phase shading's colours, named, as HTML spans.
std::string PhaseLegendHtml();

}  // namespace hexsim::reports
