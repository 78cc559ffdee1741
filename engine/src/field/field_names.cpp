// The names of the field's enumerations, as the tool prints and parses them.
#include <shrefract/field.h>

namespace shrefract {

const char* toString(SampleLayout layout) {
  switch (layout) {
    case SampleLayout::Split: return "split";
    case SampleLayout::Charts: return "charts";
  }
  return "unknown";
}

const char* toString(Quantization quantization) {
  switch (quantization) {
    case Quantization::U8: return "u8";
    case Quantization::F16: return "f16";
  }
  return "unknown";
}

const char* toString(SmoothingWindow window) {
  switch (window) {
    case SmoothingWindow::None: return "none";
    case SmoothingWindow::Hann: return "hann";
    case SmoothingWindow::Lanczos: return "lanczos";
  }
  return "unknown";
}

const char* toString(Encoding encoding) {
  switch (encoding) {
    case Encoding::Sh: return "sh";
    case Encoding::Table: return "table";
    case Encoding::Pca: return "pca";
    case Encoding::Volume: return "volume";
  }
  return "unknown";
}

const char* toString(DirectionSampling sampling) {
  switch (sampling) {
    case DirectionSampling::Grid: return "grid";
    case DirectionSampling::Nodes: return "nodes";
  }
  return "unknown";
}

const char* toString(ExitFrame frame) {
  switch (frame) {
    case ExitFrame::Object: return "object";
    case ExitFrame::Sample: return "sample";
    case ExitFrame::Auto: return "auto";
  }
  return "unknown";
}

const char* toString(ShFit fit) {
  switch (fit) {
    case ShFit::LeastSquares: return "least-squares";
    case ShFit::Robust: return "robust";
  }
  return "unknown";
}

const char* toString(PathRule rule) {
  switch (rule) {
    case PathRule::HighestEnergy: return "highest-energy";
    case PathRule::FirstRefraction: return "first-refraction";
  }
  return "unknown";
}

}  // namespace shrefract
