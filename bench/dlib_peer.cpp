// dlib itself, as a peer for measurement only (not part of glyptic): its HOG face detector and
// its 68-point shape predictor on grey images, timed, with the points printed as JSON lines.
//
// Build: g++ -O2 -std=c++14 bench/dlib_peer.cpp $(pkg-config --cflags --libs dlib-1) -o dlib_peer
// Usage: dlib_peer MODEL.dat REPEATS UPSAMPLE < jobs
//   each job line: IMAGE.pgm [l t r b]...   (binary PGM, P5, 8-bit; boxes are dlib rectangles)
//   prints per job: {"image": ..., "hog_ms": median, "hog_boxes": [[l,t,r,b]...],
//   "faces": [{"box": [l,t,r,b], "given": bool, "predict_ms": median, "points": [[x,y]...]}]}
#include <dlib/image_processing.h>
#include <dlib/image_processing/frontal_face_detector.h>
#include <dlib/image_transforms.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

using namespace dlib;

static bool read_pgm(const std::string& path, array2d<unsigned char>& img) {
  std::ifstream f(path, std::ios::binary);
  std::string magic;
  int w = 0, h = 0, maxv = 0;
  if (!(f >> magic >> w >> h >> maxv) || magic != "P5" || maxv != 255 || w <= 0 || h <= 0) return false;
  f.get();
  img.set_size(h, w);
  for (int y = 0; y < h; ++y) {
    if (!f.read(reinterpret_cast<char*>(&img[y][0]), w)) return false;
  }
  return true;
}

template <typename F>
static double median_ms(int repeats, F&& f) {
  std::vector<double> t;
  for (int i = 0; i < repeats; ++i) {
    auto a = std::chrono::steady_clock::now();
    f();
    auto b = std::chrono::steady_clock::now();
    t.push_back(std::chrono::duration<double, std::milli>(b - a).count());
  }
  std::sort(t.begin(), t.end());
  return t[t.size() / 2];
}

static std::string rect_json(const rectangle& r) {
  std::ostringstream o;
  o << "[" << r.left() << "," << r.top() << "," << r.right() << "," << r.bottom() << "]";
  return o.str();
}

int main(int argc, char** argv) {
  if (argc != 4) {
    std::cerr << "usage: dlib_peer MODEL.dat REPEATS UPSAMPLE < jobs\n";
    return 2;
  }
  shape_predictor sp;
  deserialize(argv[1]) >> sp;
  const int repeats = std::max(1, std::atoi(argv[2]));
  const int upsample = std::max(0, std::atoi(argv[3]));
  frontal_face_detector detector = get_frontal_face_detector();
  std::string line;
  while (std::getline(std::cin, line)) {
    std::istringstream in(line);
    std::string path;
    if (!(in >> path)) continue;
    array2d<unsigned char> img;
    if (!read_pgm(path, img)) {
      std::cout << "{\"image\": \"" << path << "\", \"error\": \"cannot read PGM\"}" << std::endl;
      continue;
    }
    std::vector<rectangle> given;
    long l, t, r, b;
    while (in >> l >> t >> r >> b) given.push_back(rectangle(l, t, r, b));

    // HOG detection as dlib's Python binding does it: upsample, detect, map the boxes back.
    std::vector<rectangle> hog;
    double hog_ms = median_ms(repeats, [&] {
      array2d<unsigned char> up;
      assign_image(up, img);
      pyramid_down<2> pyr;
      for (int i = 0; i < upsample; ++i) pyramid_up(up, pyr);
      hog = detector(up);
      for (auto& rr : hog)
        for (int i = 0; i < upsample; ++i) rr = pyr.rect_down(rr);
    });

    std::ostringstream out;
    out << "{\"image\": \"" << path << "\", \"hog_ms\": " << hog_ms << ", \"hog_boxes\": [";
    for (size_t i = 0; i < hog.size(); ++i) out << (i ? "," : "") << rect_json(hog[i]);
    out << "], \"faces\": [";
    std::vector<std::pair<rectangle, bool>> boxes;
    for (auto& rr : hog) boxes.push_back({rr, false});
    for (auto& rr : given) boxes.push_back({rr, true});
    for (size_t i = 0; i < boxes.size(); ++i) {
      full_object_detection shape;
      double ms = median_ms(repeats, [&] { shape = sp(img, boxes[i].first); });
      out << (i ? "," : "") << "{\"box\": " << rect_json(boxes[i].first)
          << ", \"given\": " << (boxes[i].second ? "true" : "false") << ", \"predict_ms\": " << ms
          << ", \"points\": [";
      for (unsigned long k = 0; k < shape.num_parts(); ++k)
        out << (k ? "," : "") << "[" << shape.part(k).x() << "," << shape.part(k).y() << "]";
      out << "]}";
    }
    out << "]}";
    std::cout << out.str() << std::endl;
  }
  return 0;
}
