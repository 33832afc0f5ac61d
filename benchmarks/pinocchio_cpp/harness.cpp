// Side-by-side timing of Pinocchio's C++ algorithms and our generated C, in one process and one run.
//
// Handwritten for benchmarks/bench_pinocchio_cpp.py, which writes the inputs and compiles this file.
// Usage: harness URDF LIBRARY DIR N REPEAT
//   URDF     the robot as URDF (read by pinocchio::urdf::buildModel)
//   LIBRARY  our compiled dynamics (.so with the generated rne, accel, inertia, gravload, coriolis)
//   DIR      folder of float64 inputs: qpin (N x nq, Pinocchio's configuration), q qd qdd (N x n),
//            p (our parameter vector, friction 0), armature (n), gravity (3)
// Prints one line per quantity: name, ns/state of ours, ns/state of Pinocchio, max |difference| / max(1, max |ours|).
#include <dlfcn.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include <pinocchio/algorithm/aba.hpp>
#include <pinocchio/algorithm/crba.hpp>
#include <pinocchio/algorithm/rnea.hpp>
#include <pinocchio/multibody.hpp>
#include <pinocchio/parsers/urdf.hpp>

typedef long long mw_int;
typedef int (*eval_fn)(const double **arg, double **res, mw_int *iw, double *w, int mem);
typedef int (*work_fn)(mw_int *sz_arg, mw_int *sz_res, mw_int *sz_iw, mw_int *sz_w);

static std::vector<double> read_doubles(const std::string &path, size_t count) {
    std::vector<double> out(count);
    std::ifstream in(path, std::ios::binary);
    in.read(reinterpret_cast<char *>(out.data()), static_cast<std::streamsize>(count * sizeof(double)));
    if (!in) {
        std::fprintf(stderr, "harness: cannot read %zu doubles from %s\n", count, path.c_str());
        std::exit(2);
    }
    return out;
}

// One generated function with its work vectors, called at one point per call.
struct Generated {
    eval_fn eval = nullptr;
    std::vector<const double *> arg;
    std::vector<double *> res;
    std::vector<mw_int> iw;
    std::vector<double> w;

    Generated(void *lib, const std::string &name) {
        eval = reinterpret_cast<eval_fn>(dlsym(lib, name.c_str()));
        work_fn work = reinterpret_cast<work_fn>(dlsym(lib, (name + "_work").c_str()));
        if (!eval || !work) {
            std::fprintf(stderr, "harness: %s not found in the library\n", name.c_str());
            std::exit(2);
        }
        mw_int a = 0, r = 0, i = 0, ww = 0;
        work(&a, &r, &i, &ww);
        arg.resize(static_cast<size_t>(a));
        res.resize(static_cast<size_t>(r));
        iw.resize(static_cast<size_t>(std::max<mw_int>(i, 1)));
        w.resize(static_cast<size_t>(std::max<mw_int>(ww, 1)));
    }
    void operator()() { eval(arg.data(), res.data(), iw.data(), w.data(), 0); }
};

// Best ns per state of each of two runs, timed alternately (a, b, a, b, ...) so that both see the same load.
static void best_pair(const std::function<void()> &a, const std::function<void()> &b, int repeat, long N,
                      double *ns_a, double *ns_b) {
    *ns_a = *ns_b = 1e300;
    for (int r = 0; r < repeat; ++r) {
        for (int which = 0; which < 2; ++which) {
            auto t0 = std::chrono::steady_clock::now();
            (which == 0 ? a : b)();
            auto t1 = std::chrono::steady_clock::now();
            double ns = std::chrono::duration<double, std::nano>(t1 - t0).count() / static_cast<double>(N);
            double *best = which == 0 ? ns_a : ns_b;
            *best = std::min(*best, ns);
        }
    }
}

static double rel_diff(const std::vector<double> &ours, const std::vector<double> &theirs) {
    double diff = 0.0, scale = 1.0;
    for (size_t k = 0; k < ours.size(); ++k) {
        diff = std::max(diff, std::fabs(ours[k] - theirs[k]));
        scale = std::max(scale, std::fabs(ours[k]));
    }
    return diff / scale;
}

int main(int argc, char **argv) {
    if (argc != 6) {
        std::fprintf(stderr, "usage: harness URDF LIBRARY DIR N REPEAT\n");
        return 2;
    }
    const std::string urdf = argv[1], dir = std::string(argv[3]) + "/";
    const long N = std::atol(argv[4]);
    const int repeat = std::atoi(argv[5]);

    pinocchio::Model model;
    pinocchio::urdf::buildModel(urdf, model);
    pinocchio::Data data(model);
    const long n = model.nv, nq = model.nq;
    std::vector<double> armature = read_doubles(dir + "armature", static_cast<size_t>(n));
    std::vector<double> gravity = read_doubles(dir + "gravity", 3);
    for (long j = 0; j < n; ++j) model.armature[j] = armature[static_cast<size_t>(j)];
    model.gravity.linear() << gravity[0], gravity[1], gravity[2];
    model.gravity.angular().setZero();

    std::ifstream psize(dir + "p", std::ios::binary | std::ios::ate);
    const size_t n_p = static_cast<size_t>(psize.tellg()) / sizeof(double);
    std::vector<double> p = read_doubles(dir + "p", n_p);
    std::vector<double> qpin = read_doubles(dir + "qpin", static_cast<size_t>(N * nq));
    std::vector<double> q = read_doubles(dir + "q", static_cast<size_t>(N * n));
    std::vector<double> qd = read_doubles(dir + "qd", static_cast<size_t>(N * n));
    std::vector<double> qdd = read_doubles(dir + "qdd", static_cast<size_t>(N * n));

    void *lib = dlopen(argv[2], RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
        std::fprintf(stderr, "harness: %s\n", dlerror());
        return 2;
    }
    Generated rne(lib, "rne"), accel(lib, "accel"), inertia(lib, "inertia"), gravload(lib, "gravload"),
        coriolis(lib, "coriolis");

    typedef Eigen::Map<const Eigen::VectorXd> CMap;
    const size_t sn = static_cast<size_t>(n), snn = sn * sn;
    std::vector<double> ours(N * snn), theirs(N * snn), tau(N * sn);

    // rne (ours with friction 0) against rnea; its torques are the input of accel and aba.
    auto run_rne = [&] {
        for (long k = 0; k < N; ++k) {
            rne.arg[0] = &q[k * n]; rne.arg[1] = &qd[k * n]; rne.arg[2] = &qdd[k * n]; rne.arg[3] = p.data();
            rne.res[0] = &tau[k * n];
            rne();
        }
    };
    auto run_rnea = [&] {
        for (long k = 0; k < N; ++k) {
            pinocchio::rnea(model, data, CMap(&qpin[k * nq], nq), CMap(&qd[k * n], n), CMap(&qdd[k * n], n));
            std::copy(data.tau.data(), data.tau.data() + n, &theirs[k * n]);
        }
    };
    double t_ours, t_pin;
    best_pair(run_rne, run_rnea, repeat, N, &t_ours, &t_pin);
    std::printf("rne %.2f %.2f %.3e\n", t_ours, t_pin,
                rel_diff(tau, std::vector<double>(theirs.begin(), theirs.begin() + N * n)));

    auto run_accel = [&] {
        for (long k = 0; k < N; ++k) {
            accel.arg[0] = &q[k * n]; accel.arg[1] = &qd[k * n]; accel.arg[2] = &tau[k * n]; accel.arg[3] = p.data();
            accel.res[0] = &ours[k * n];
            accel();
        }
    };
    auto run_aba = [&] {
        for (long k = 0; k < N; ++k) {
            pinocchio::aba(model, data, CMap(&qpin[k * nq], nq), CMap(&qd[k * n], n), CMap(&tau[k * n], n),
                           pinocchio::Convention::WORLD);
            std::copy(data.ddq.data(), data.ddq.data() + n, &theirs[k * n]);
        }
    };
    best_pair(run_accel, run_aba, repeat, N, &t_ours, &t_pin);
    std::printf("accel %.2f %.2f %.3e\n", t_ours, t_pin,
                rel_diff(std::vector<double>(ours.begin(), ours.begin() + N * n),
                         std::vector<double>(theirs.begin(), theirs.begin() + N * n)));

    auto run_inertia = [&] {
        for (long k = 0; k < N; ++k) {
            inertia.arg[0] = &q[k * n]; inertia.arg[1] = p.data();
            inertia.res[0] = &ours[k * snn];
            inertia();
        }
    };
    auto run_crba = [&] {  // the upper triangle, as crba leaves it; mirrored below for the comparison
        for (long k = 0; k < N; ++k) {
            pinocchio::crba(model, data, CMap(&qpin[k * nq], nq), pinocchio::Convention::WORLD);
            std::copy(data.M.data(), data.M.data() + n * n, &theirs[k * snn]);
        }
    };
    best_pair(run_inertia, run_crba, repeat, N, &t_ours, &t_pin);
    for (long k = 0; k < N; ++k)
        for (long c = 0; c < n; ++c)
            for (long r = c + 1; r < n; ++r) theirs[k * snn + c * n + r] = theirs[k * snn + r * n + c];
    std::printf("inertia %.2f %.2f %.3e\n", t_ours, t_pin, rel_diff(ours, theirs));

    auto run_gravload = [&] {
        for (long k = 0; k < N; ++k) {
            gravload.arg[0] = &q[k * n]; gravload.arg[1] = p.data();
            gravload.res[0] = &ours[k * n];
            gravload();
        }
    };
    auto run_gravity = [&] {
        for (long k = 0; k < N; ++k) {
            pinocchio::computeGeneralizedGravity(model, data, CMap(&qpin[k * nq], nq));
            std::copy(data.g.data(), data.g.data() + n, &theirs[k * n]);
        }
    };
    best_pair(run_gravload, run_gravity, repeat, N, &t_ours, &t_pin);
    std::printf("gravload %.2f %.2f %.3e\n", t_ours, t_pin,
                rel_diff(std::vector<double>(ours.begin(), ours.begin() + N * n),
                         std::vector<double>(theirs.begin(), theirs.begin() + N * n)));

    auto run_coriolis = [&] {
        for (long k = 0; k < N; ++k) {
            coriolis.arg[0] = &q[k * n]; coriolis.arg[1] = &qd[k * n]; coriolis.arg[2] = p.data();
            coriolis.res[0] = &ours[k * snn];
            coriolis();
        }
    };
    auto run_coriolis_pin = [&] {
        for (long k = 0; k < N; ++k) {
            pinocchio::computeCoriolisMatrix(model, data, CMap(&qpin[k * nq], nq), CMap(&qd[k * n], n));
            std::copy(data.C.data(), data.C.data() + n * n, &theirs[k * snn]);
        }
    };
    best_pair(run_coriolis, run_coriolis_pin, repeat, N, &t_ours, &t_pin);
    std::printf("coriolis %.2f %.2f %.3e\n", t_ours, t_pin, rel_diff(ours, theirs));
    return 0;
}
