// SPDX-License-Identifier: Apache-2.0
// nebrender - single-scattering ray caster: scattered starlight + gas emission to EXR/PNG.
#include "nebula/cli/render_command.h"

int main(int argc, char** argv)
{
    nebula::cli::RenderCommand command;

    CLI::App app{
        "nebrender - render a nebula: starlight scattered by dust, plus gas emission\n\n"
        "Examples:\n"
        "  nebrender -i lit.vdb -o frame.exr                 # also writes frame.png\n"
        "  nebscatter -i lit.vdb -o s.vdb && nebrender -i s.vdb -o f.exr  # all orders\n"
        "  nebrender -i lit.vdb --eye 0,0,-25 --look-at 0,0,0 --fov 40 --res 1024x768 -o f.exr\n"
        "  nebrender -i lit.vdb --rv 5 --albedo 0.6 --g 0.6 -o rv5.exr\n"
        "  nebphase -i lit.vdb -o phase.vdb && nebrender -i lit.vdb --phase phase.vdb -o f.exr\n"
        "  nebrender -i lit.vdb --integrator path --spp 256 -o reference.exr\n"
        "  nebrender -i lit.vdb --camera fisheye --eye 0,0,-5 --res 1024x1024 -o dome.exr\n"
        "  nebrender -i lit.vdb --camera equirect --eye 0,0,-5 --res 2048x1024 -o 360.exr\n"
        "  nebrender -i lit.vdb --spectral -o spectral.exr      # lines, black bodies, Doppler\n"
        "  nebrender -i shell.vdb --spectral --exaggerate-velocity 50 --spectral-layers 47 -o "
        "d.exr\n"
        "  nebgen -o - | nebillum -i - -o - | nebrender -i - -o frame.exr\n\n"
        "Needs the density grid, the tau.<star> grids from nebillum and nebula:stars;\n"
        "uses the emission grid if present, and nebscatter's scattered-light field if present\n"
        "(the light scattered more than once, right at every optical depth). EXR: linear radiance "
        "[L_sun pc^-2 sr^-1], R,G,B,A\n"
        "(A = 1 - transmittance), layers star.<name>.R/G/B and transmittance.R/G/B (and\n"
        "variance.R/G/B, the squared standard error of each pixel, with --integrator path).\n"
        "PNG: sRGB after the automatic exposure and tone curve (or --exposure).\n"
        "--spectral: spectra per ray (360-830 nm) instead of R,G,B: line emission from each\n"
        "emission grid's nebula:lines (Doppler-shifted by the velocity grid, v_r > 0\n"
        "receding: lambda' = lambda (1 + v_r/c)), black-body (Kirchhoff) emission from the\n"
        "temperature grid, starlight scattered by dust with the extinction curve at every\n"
        "wavelength (and more than once from nebscatter --spectral's field, if present);\n"
        "colour = CIE 1931 XYZ -> linear sRGB (may be negative out of gamut).",
        "nebrender"};
    nebula::cli::addRenderCommand(app, command);
    return nebula::cli::run(app, "nebrender", command.common, argc, argv, [&](nebula::Run& run) {
        nebula::cli::runRenderCommand(app, command, run);
    });
}
