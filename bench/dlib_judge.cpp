// dlib_embed: compute dlib's 128-d face descriptors (dlib_face_recognition_resnet_model_v1)
// from externally supplied 68-point iBUG landmarks.
//
// usage:  dlib_embed MODEL.dat [BATCH] < input.txt > output.txt
// input:  one line per face: PATH x1 y1 ... x68 y68   (0-based image pixels, iBUG/dlib order)
// output: one line per input line, same order: PATH d1 ... d128   (%.6f)
//         or: PATH ERROR reason
// Debug: DLIB_EMBED_CHIPS=DIR writes each aligned 150x150 chip to DIR/chip_<n>.png (n = 0-based output line).
// DLIB_JUDGE_DETECT=shape_predictor_68_face_landmarks.dat: the face found by dlib itself, as the
// face_recognition package does by default (the HOG detector on the image upsampled once, the
// largest face, dlib's 68-point predictor); the line's coordinates, if any, are ignored, and an
// image where HOG finds no face is "PATH ERROR no face".
// Paths must not contain whitespace. Empty lines and lines starting with '#' are skipped.
// Network definition from dlib/examples/dnn_face_recognition_ex.cpp (dlib, Boost Software
// License). A measuring tool only (issue #37): glyptic never runs or links this network, so
// it judges the gems as a network nobody tuned them against. Built by scripts/bench-likeness.sh.

#include <dlib/dnn.h>
#include <dlib/image_io.h>
#include <dlib/image_transforms.h>
#include <dlib/image_processing/full_object_detection.h>
#include <dlib/image_processing/frontal_face_detector.h>
#include <dlib/image_processing/shape_predictor.h>

#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

using namespace dlib;
using namespace std;

// ----------------------------------------------------------------------------------------
// Network definition, verbatim from dnn_face_recognition_ex.cpp

template <template <int,template<typename>class,int,typename> class block, int N, template<typename>class BN, typename SUBNET>
using residual = add_prev1<block<N,BN,1,tag1<SUBNET>>>;

template <template <int,template<typename>class,int,typename> class block, int N, template<typename>class BN, typename SUBNET>
using residual_down = add_prev2<avg_pool<2,2,2,2,skip1<tag2<block<N,BN,2,tag1<SUBNET>>>>>>;

template <int N, template <typename> class BN, int stride, typename SUBNET>
using block  = BN<con<N,3,3,1,1,relu<BN<con<N,3,3,stride,stride,SUBNET>>>>>;

template <int N, typename SUBNET> using ares      = relu<residual<block,N,affine,SUBNET>>;
template <int N, typename SUBNET> using ares_down = relu<residual_down<block,N,affine,SUBNET>>;

template <typename SUBNET> using alevel0 = ares_down<256,SUBNET>;
template <typename SUBNET> using alevel1 = ares<256,ares<256,ares_down<256,SUBNET>>>;
template <typename SUBNET> using alevel2 = ares<128,ares<128,ares_down<128,SUBNET>>>;
template <typename SUBNET> using alevel3 = ares<64,ares<64,ares<64,ares_down<64,SUBNET>>>>;
template <typename SUBNET> using alevel4 = ares<32,ares<32,ares<32,SUBNET>>>;

using anet_type = loss_metric<fc_no_bias<128,avg_pool_everything<
                            alevel0<
                            alevel1<
                            alevel2<
                            alevel3<
                            alevel4<
                            max_pool<3,3,2,2,relu<affine<con<32,7,7,2,2,
                            input_rgb_image_sized<150>
                            >>>>>>>>>>>>;

// ----------------------------------------------------------------------------------------
// Minimal binary/ASCII PNM reader (P2/P3/P5/P6), since dlib::load_image has no PPM support.

static bool pnm_token(istream& in, string& tok)
{
    tok.clear();
    int c;
    while ((c = in.get()) != EOF)
    {
        if (c == '#') { while ((c = in.get()) != EOF && c != '\n') {} continue; }
        if (isspace(c)) { if (!tok.empty()) return true; continue; }
        tok.push_back((char)c);
    }
    return !tok.empty();
}

static bool load_pnm(const string& path, matrix<rgb_pixel>& img, string& err)
{
    ifstream in(path, ios::binary);
    if (!in) { err = "cannot open file"; return false; }
    string magic, sw, sh, smax;
    if (!pnm_token(in, magic) || magic.size() != 2 || magic[0] != 'P') { err = "not a PNM file"; return false; }
    const char t = magic[1];
    if (t != '2' && t != '3' && t != '5' && t != '6') { err = "unsupported PNM type " + magic; return false; }
    if (!pnm_token(in, sw) || !pnm_token(in, sh) || !pnm_token(in, smax)) { err = "bad PNM header"; return false; }
    const long w = atol(sw.c_str()), h = atol(sh.c_str()), maxv = atol(smax.c_str());
    if (w <= 0 || h <= 0 || maxv <= 0 || maxv > 65535) { err = "bad PNM header values"; return false; }
    const int ch = (t == '3' || t == '6') ? 3 : 1;
    img.set_size(h, w);
    auto scale = [maxv](long v) { return (unsigned char)std::min(255L, (v * 255 + maxv / 2) / maxv); };
    std::vector<long> px((size_t)w * h * ch);
    if (t == '5' || t == '6')
    {
        const int bps = maxv > 255 ? 2 : 1;
        std::vector<unsigned char> buf(px.size() * bps);
        in.read((char*)buf.data(), buf.size());
        if ((size_t)in.gcount() != buf.size()) { err = "truncated PNM data"; return false; }
        for (size_t i = 0; i < px.size(); ++i)
            px[i] = bps == 1 ? buf[i] : (buf[2 * i] << 8 | buf[2 * i + 1]);
    }
    else
    {
        string tok;
        for (size_t i = 0; i < px.size(); ++i)
        {
            if (!pnm_token(in, tok)) { err = "truncated PNM data"; return false; }
            px[i] = atol(tok.c_str());
        }
    }
    for (long r = 0; r < h; ++r)
        for (long c = 0; c < w; ++c)
        {
            const size_t i = ((size_t)r * w + c) * ch;
            if (ch == 3) img(r, c) = rgb_pixel(scale(px[i]), scale(px[i + 1]), scale(px[i + 2]));
            else { unsigned char g = scale(px[i]); img(r, c) = rgb_pixel(g, g, g); }
        }
    return true;
}

static bool load_any(const string& path, matrix<rgb_pixel>& img, string& err)
{
    {
        ifstream in(path, ios::binary);
        if (!in) { err = "cannot open file"; return false; }
        char m[2] = {0, 0};
        in.read(m, 2);
        if (m[0] == 'P' && m[1] >= '1' && m[1] <= '6')
            return load_pnm(path, img, err);
    }
    try { load_image(img, path); }
    catch (std::exception& e) { err = string("image load failed: ") + e.what(); return false; }
    if (img.size() == 0) { err = "empty image"; return false; }
    return true;
}

// ----------------------------------------------------------------------------------------

struct pending { size_t out_index; matrix<rgb_pixel> chip; };

int main(int argc, char** argv)
{
    if (argc < 2 || argc > 3)
    {
        cerr << "usage: " << argv[0] << " dlib_face_recognition_resnet_model_v1.dat [batch_size=32] < input > output\n"
             << "input lines:  PATH x1 y1 ... x68 y68   (0-based pixels, iBUG 68-point order)\n"
             << "output lines: PATH d1 ... d128  |  PATH ERROR reason\n";
        return 2;
    }
    const size_t batch = argc == 3 ? std::max(1, atoi(argv[2])) : 32;

    anet_type net;
    try { deserialize(argv[1]) >> net; }
    catch (std::exception& e) { cerr << "failed to load model " << argv[1] << ": " << e.what() << "\n"; return 1; }

    // With DLIB_JUDGE_DETECT, dlib finds the face and its landmarks itself.
    const char* sp_path = getenv("DLIB_JUDGE_DETECT");
    frontal_face_detector hog;
    shape_predictor sp;
    if (sp_path)
    {
        hog = get_frontal_face_detector();
        try { deserialize(sp_path) >> sp; }
        catch (std::exception& e) { cerr << "failed to load shape predictor " << sp_path << ": " << e.what() << "\n"; return 1; }
    }

    std::vector<string> out;        // one output line per input line, in order
    std::vector<pending> todo;
    double t_prep = 0, t_net = 0;
    size_t n_faces = 0;

    auto flush = [&]() {
        if (todo.empty()) return;
        std::vector<matrix<rgb_pixel>> chips;
        chips.reserve(todo.size());
        for (auto& p : todo) chips.push_back(std::move(p.chip));
        auto t0 = chrono::steady_clock::now();
        std::vector<matrix<float,0,1>> desc = net(chips, batch);
        t_net += chrono::duration<double>(chrono::steady_clock::now() - t0).count();
        for (size_t i = 0; i < todo.size(); ++i)
        {
            string& s = out[todo[i].out_index];
            char b[32];
            for (long k = 0; k < desc[i].size(); ++k) { snprintf(b, sizeof b, " %.6f", desc[i](k)); s += b; }
        }
        n_faces += todo.size();
        todo.clear();
    };

    // Cache the most recently loaded image (consecutive lines often share one image).
    string cached_path;
    matrix<rgb_pixel> cached_img;
    bool cached_ok = false;
    string cached_err;

    // Debug: if DLIB_EMBED_CHIPS=DIR is set, the aligned 150x150 chips are written to DIR/chip_<line>.png
    const char* chip_dir = getenv("DLIB_EMBED_CHIPS");

    string line;
    while (getline(cin, line))
    {
        if (!line.empty() && line.back() == '\r') line.pop_back();
        istringstream ss(line);
        string path;
        if (!(ss >> path) || path[0] == '#') continue;
        out.push_back(path);
        string& o = out.back();

        std::vector<double> v;
        string tok;
        bool bad_num = false;
        while (ss >> tok)
        {
            char* end = nullptr;
            double d = strtod(tok.c_str(), &end);
            if (end == tok.c_str() || *end != 0) { bad_num = true; break; }
            v.push_back(d);
        }
        if (bad_num) { o += " ERROR non-numeric coordinate '" + tok + "'"; continue; }
        if (!sp_path && v.size() != 136) { o += " ERROR expected 136 numbers (68 points), got " + to_string(v.size()); continue; }

        auto t0 = chrono::steady_clock::now();
        if (path != cached_path)
        {
            cached_path = path;
            cached_img.set_size(0, 0);
            cached_ok = load_any(path, cached_img, cached_err);
        }
        if (!cached_ok) { o += " ERROR " + cached_err; continue; }

        full_object_detection shape;
        if (sp_path)
        {
            matrix<rgb_pixel> up;
            pyramid_up(cached_img, up, pyramid_down<2>());
            std::vector<rectangle> faces = hog(up);
            if (faces.empty()) { o += " ERROR no face"; continue; }
            rectangle big = faces[0];
            for (auto& f : faces) if (f.area() > big.area()) big = f;
            // Back to the image's own pixels (pyramid_up doubles them).
            rectangle box((big.left() + 1) / 2, (big.top() + 1) / 2, big.right() / 2, big.bottom() / 2);
            shape = sp(cached_img, box);
        }
        else
        {
            std::vector<point> parts(68);
            double minx = 1e300, miny = 1e300, maxx = -1e300, maxy = -1e300;
            for (int i = 0; i < 68; ++i)
            {
                const double x = v[2 * i], y = v[2 * i + 1];
                parts[i] = point((long)std::lround(x), (long)std::lround(y));
                minx = std::min(minx, x); maxx = std::max(maxx, x);
                miny = std::min(miny, y); maxy = std::max(maxy, y);
            }
            rectangle rect((long)std::floor(minx), (long)std::floor(miny), (long)std::ceil(maxx), (long)std::ceil(maxy));
            shape = full_object_detection(rect, parts);
        }

        pending p;
        p.out_index = out.size() - 1;
        extract_image_chip(cached_img, get_face_chip_details(shape, 150, 0.25), p.chip);
        if (chip_dir)
        {
            char b[64]; snprintf(b, sizeof b, "/chip_%05zu.png", p.out_index);
            try { save_png(p.chip, string(chip_dir) + b); } catch (std::exception& e) { cerr << "chip save failed: " << e.what() << "\n"; }
        }
        t_prep += chrono::duration<double>(chrono::steady_clock::now() - t0).count();
        todo.push_back(std::move(p));
        if (todo.size() >= batch) flush();
    }
    flush();

    for (auto& s : out) fputs((s + "\n").c_str(), stdout);
    fflush(stdout);
    if (n_faces)
        fprintf(stderr, "dlib_embed: %zu faces, %zu lines; load+chip %.1f ms/face, network %.1f ms/face\n",
                n_faces, out.size(), 1000 * t_prep / n_faces, 1000 * t_net / n_faces);
    return 0;
}
