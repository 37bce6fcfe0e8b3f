//! `lampost`: the command line of the lampost CAM post-processor and setup toolkit.
//!
//! The binary is thin: it parses arguments (clap), opens files, renders diagnostics and
//! JSON; the work is done in the library crates.

mod align_cmds;
mod calib_cmds;
mod docs;
mod gcode_cmds;
mod inspect_cmds;
mod io;
mod json;
mod kin_cmds;
mod mesh_cmds;
mod plan_cmds;
mod points;
mod post_cmds;
mod posted;
mod progress;
mod report;
mod robot_cmds;

use clap::{Parser, Subcommand, ValueEnum};

use report::CliError;

#[derive(Parser, Debug)]
#[command(
    name = "lampost",
    version,
    about = "CAM post-processor and setup toolkit for hybrid laser-deposition / machining 5-axis machines"
)]
pub(crate) struct Cli {
    #[command(subcommand)]
    command: Command,
}

/// Units a program starts in, before any G20/G21.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum UnitsArg {
    /// Inches (G20).
    Inch,
    /// Millimetres (G21).
    Mm,
}

/// What the E word means.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum EWordArg {
    /// FADAL fixture offset E0–E48.
    Fixture,
    /// Slicer extrusion.
    Extrusion,
}

/// The control a program was written for (`auto`: decided from the program's content).
#[derive(Debug, Clone, Copy, ValueEnum, Default, PartialEq, Eq)]
pub enum FlavorArg {
    /// Decide from the program's first 64 KiB (slicer comments, M82/M83, O-words, macros).
    #[default]
    Auto,
    /// LinuxCNC: parameters, expressions and O-words evaluated.
    Linuxcnc,
    /// Fanuc: Macro B evaluated (variables, IF/GOTO/WHILE, G65 macros).
    Fanuc,
    /// Haas: Fanuc Macro B evaluated; M97 local subprograms.
    Haas,
    /// FADAL.
    Fadal,
    /// Mach3.
    Mach3,
    /// Marlin (slicer programs: E is extrusion).
    Marlin,
    /// RepRapFirmware (slicer programs: E is extrusion).
    Reprap,
    /// MakerBot/Sailfish (slicer programs: the extruder is the A or B word).
    Makerbot,
}

impl FlavorArg {
    /// The library's flavour.
    pub fn flavor(self) -> lampost_gcode::Flavor {
        use lampost_gcode::Flavor as F;
        match self {
            FlavorArg::Auto => F::Auto,
            FlavorArg::Linuxcnc => F::LinuxCnc,
            FlavorArg::Fanuc => F::Fanuc,
            FlavorArg::Haas => F::Haas,
            FlavorArg::Fadal => F::Fadal,
            FlavorArg::Mach3 => F::Mach3,
            FlavorArg::Marlin => F::Marlin,
            FlavorArg::Reprap => F::RepRap,
            FlavorArg::Makerbot => F::MakerBot,
        }
    }
}

/// Output dialect.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum DialectArg {
    /// FADAL (% framing, forced decimal points, fixed decimals).
    Fadal,
    /// Plain ISO/RS274.
    Iso,
}

/// Settings shared by the commands that interpret programs.
#[derive(clap::Args, Debug, Clone, Copy)]
pub struct InterpArgs {
    /// Units before the program's first G20/G21.
    #[arg(long, value_enum, default_value = "mm")]
    units: UnitsArg,
    /// Meaning of E words (default: the flavour's: extrusion for marlin and reprap).
    #[arg(long = "e-word", value_enum)]
    e_word: Option<EWordArg>,
    /// The control the program was written for.
    #[arg(long, value_enum, default_value = "auto")]
    flavor: FlavorArg,
    /// Skip blocks that start with `/` (the block-delete switch on).
    #[arg(long)]
    block_delete: bool,
}

/// `lampost machines` subcommands.
#[derive(Subcommand, Debug)]
enum MachinesCmd {
    /// Print a built-in machine's TOML, to copy and edit.
    Show {
        /// Built-in machine name.
        name: String,
    },
}

/// Options every kinematics command takes.
#[derive(clap::Args, Debug, Clone)]
pub struct MachineArgs {
    /// Built-in machine name (see `lampost machines`) or the path of a machine file.
    #[arg(long)]
    machine: String,
    /// Head: spindle, probe, laser, sensor… (as the machine defines; default its first head).
    #[arg(long)]
    head: Option<String>,
    /// Override a parameter: NAME=x,y,z or NAME=value (repeatable).
    #[arg(long = "set", value_name = "NAME=VALUE")]
    set: Vec<String>,
    /// Write JSON.
    #[arg(long)]
    json: bool,
}

/// `lampost kin` subcommands.
#[derive(Subcommand, Debug)]
enum KinCmd {
    /// Forward kinematics: joints → tool tip and tool axis in the part frame.
    Fk {
        /// Every axis: X=..,Y=..,Z=..,A=..,B=..
        #[arg(long)]
        joints: String,
        #[command(flatten)]
        m: MachineArgs,
    },
    /// Inverse kinematics: tool tip and axis in the part frame → every joint solution, best first.
    Ik {
        /// Tool tip x,y,z in the part frame.
        #[arg(long, allow_hyphen_values = true, required_unless_present = "points")]
        position: Option<String>,
        /// Tool axis i,j,k (from the tip into the head), part frame.
        #[arg(long, allow_hyphen_values = true, required_unless_present = "points")]
        axis: Option<String>,
        /// Or many poses: a point file with a header naming x y z i j k (tip and tool axis per row; - for standard input), solved together by the batch solver; one row of joints out per pose (the best within limits, ranked from --near).
        #[arg(long, conflicts_with_all = ["position", "axis"])]
        points: Option<String>,
        /// Previous rotary position, e.g. A=0,B=0 (default all 0).
        #[arg(long, allow_hyphen_values = true)]
        near: Option<String>,
        #[command(flatten)]
        m: MachineArgs,
    },
    /// Part points rotated by the table, as the machine sees them (the repair-patch transform).
    Rotate {
        /// Rotary axes: A=..,B=..
        #[arg(long, allow_hyphen_values = true)]
        joints: String,
        /// Point file (x y z per line), or - for standard input.
        file: String,
        #[command(flatten)]
        m: MachineArgs,
    },
}

/// `lampost align` subcommands.
#[derive(Subcommand, Debug)]
enum AlignCmd {
    /// 6-DOF best-fit registration of probed points to an STL mesh (point-to-plane).
    Register {
        /// Probed points (part frame).
        file: String,
        /// The part's STL (CAD frame), ASCII or binary.
        #[arg(long)]
        mesh: String,
        /// Hold degrees of freedom: x, y, z, rx, ry, rz, tilt (= rx, ry), e.g. z,tilt.
        #[arg(long)]
        lock: Option<String>,
        /// Write the setup (CAD frame on the part) for `lampost post --setup`.
        #[arg(long)]
        write_setup: Option<String>,
        /// Write JSON.
        #[arg(long)]
        json: bool,
    },
    /// Levelling: the rotary positions that make a probed surface's outward normal the tool axis.
    Level {
        /// Probed points on the surface.
        file: String,
        /// Built-in machine name or machine file.
        #[arg(long)]
        machine: String,
        /// Previous rotary position, e.g. A=0,B=0.
        #[arg(long, allow_hyphen_values = true)]
        near: Option<String>,
        /// A direction pointing out of the material (default: the +Z side).
        #[arg(long, allow_hyphen_values = true)]
        outward: Option<String>,
        /// Override a machine parameter (repeatable).
        #[arg(long = "set", value_name = "NAME=VALUE")]
        set: Vec<String>,
        /// Write JSON.
        #[arg(long)]
        json: bool,
    },
    /// The angle between a probed plane and a CAD plane (paper 002, eq. 1), the aligning rotation and setup.
    Angle {
        /// Probed points on the plane.
        file: String,
        /// The CAD plane's normal i,j,k.
        #[arg(long, allow_hyphen_values = true)]
        to_normal: Option<String>,
        /// Or a second probed plane.
        #[arg(long)]
        to_plane: Option<String>,
        /// Origin of the program frame for the setup (default: the probed plane's centroid).
        #[arg(long, allow_hyphen_values = true)]
        origin: Option<String>,
        /// Write the setup file `lampost post --setup` reads.
        #[arg(long)]
        write_setup: Option<String>,
        /// Write JSON.
        #[arg(long)]
        json: bool,
    },
}

/// `lampost calibrate` subcommands.
#[derive(Subcommand, Debug)]
enum CalibrateCmd {
    /// The rotation centre / R from ball centres measured at several rotary poses.
    Pivot {
        /// Rows `A B x y z [ux uy uz]`: rotary angles and the measured ball centre (machine coordinates); or the RS-232 log of a `probe poses` program (each pose's centre fitted from its touches).
        poses: String,
        #[command(flatten)]
        ball: LogBall,
        /// i (sphere of centres), iii (eq. 21, least squares), fit (both axis lines); default fit (iii under 4 poses).
        #[arg(long)]
        method: Option<String>,
        /// Write the machine file with the calibration applied.
        #[arg(long)]
        write: Option<String>,
        #[command(flatten)]
        m: CalibMachine,
    },
    /// Each rotary axis as a line from poses that move one axis at a time; ISO 230-1 style location errors.
    Axes {
        /// Rows `A B x y z`, or the RS-232 log of a `probe poses` program.
        poses: String,
        #[command(flatten)]
        ball: LogBall,
        #[command(flatten)]
        m: CalibMachine,
    },
    /// Method II: the 2³ factorial design (--start, --step) or its regression (--fit RESULTS).
    Factorial {
        /// Start centre x,y,z.
        #[arg(long, allow_hyphen_values = true)]
        start: Option<String>,
        /// Step (the factor level).
        #[arg(long)]
        step: Option<f64>,
        /// Rows `x y z variation` (or `run x y z variation`).
        #[arg(long)]
        fit: Option<String>,
        /// Write JSON.
        #[arg(long)]
        json: bool,
    },
    /// The spindle-to-laser offset L from burn marks.
    Laser {
        /// Machine position where a mark was burned (repeatable).
        #[arg(long, allow_hyphen_values = true)]
        burned: Vec<String>,
        /// Probed position of that mark (repeatable, in the same order).
        #[arg(long, allow_hyphen_values = true)]
        probed: Vec<String>,
        /// Or rows `bx by bz px py pz`.
        file: Option<String>,
        /// Write JSON.
        #[arg(long)]
        json: bool,
    },
}

/// The radii for fitting each pose of a `probe poses` log.
#[derive(clap::Args, Debug, Clone)]
pub struct LogBall {
    /// With a log: the gage ball's radius (with --stylus-radius, fixes each pose's sphere fit at their sum; without both, the radius is fitted).
    #[arg(long)]
    radius: Option<f64>,
    /// With a log: the stylus ball's radius.
    #[arg(long)]
    stylus_radius: Option<f64>,
}

impl LogBall {
    fn size(&self) -> calib_cmds::BallSize {
        calib_cmds::BallSize {
            radius: self.radius,
            stylus_radius: self.stylus_radius,
        }
    }
}

/// Machine options of the calibration commands.
#[derive(clap::Args, Debug, Clone)]
pub struct CalibMachine {
    /// Built-in machine name or machine file.
    #[arg(long)]
    machine: String,
    /// Override a parameter (repeatable).
    #[arg(long = "set", value_name = "NAME=VALUE")]
    set: Vec<String>,
    /// Write JSON.
    #[arg(long)]
    json: bool,
}

/// `lampost probe` subcommands.
#[derive(Subcommand, Debug)]
enum ProbeCmd {
    /// A FADAL program that indexes the rotaries through a pose set and probes the gage ball at each.
    Poses {
        /// Built-in machine name or machine file.
        #[arg(long)]
        machine: String,
        /// Override a parameter (repeatable).
        #[arg(long = "set", value_name = "NAME=VALUE")]
        set: Vec<String>,
        /// Ball centre x,y,z at A = B = 0, machine coordinates.
        #[arg(long, allow_hyphen_values = true)]
        ball: String,
        /// Poses "A=0,B=0;A=90,B=45;…" (default: the set --for names).
        #[arg(long)]
        poses: Option<String>,
        /// The default set serves: pivot (four platter angles at two tilts, for `calibrate pivot`) or axes (adds tilts at the platter's home, so each axis turns alone through three angles, for `calibrate axes` and `calibrate pivot`).
        #[arg(long = "for", value_name = "pivot|axes", default_value = "pivot")]
        for_: String,
        /// Ball radius.
        #[arg(long)]
        radius: f64,
        /// Stylus ball radius.
        #[arg(long)]
        stylus_radius: f64,
        /// Touches per pose.
        #[arg(long, default_value_t = 12)]
        points: usize,
        /// Output file (atomic); standard output if absent.
        #[arg(short, long)]
        output: Option<String>,
    },
    /// A FADAL program that touches a gage ball at N points and prints each touch.
    Sphere {
        /// Estimated ball centre x,y,z.
        #[arg(long, allow_hyphen_values = true)]
        center: String,
        /// Ball radius.
        #[arg(long)]
        radius: f64,
        /// Stylus ball radius.
        #[arg(long)]
        stylus_radius: f64,
        /// Number of touches.
        #[arg(long, default_value_t = 30)]
        points: usize,
        /// Largest polar angle from +Z the touches reach (clear of the stem).
        #[arg(long, default_value_t = 90.0)]
        cap_deg: f64,
        /// Program units.
        #[arg(long, value_enum, default_value = "inch")]
        units: UnitsArg,
        /// Program number.
        #[arg(long, default_value_t = 9500)]
        program_number: u32,
        /// Output file (atomic); standard output if absent.
        #[arg(short, long)]
        output: Option<String>,
    },
    /// A FADAL program that touches a grid over a rectangle on a +Z face.
    Plane {
        /// One corner x,y,z of the rectangle on the face.
        #[arg(long, allow_hyphen_values = true)]
        corner: String,
        /// Size u,v along X and Y.
        #[arg(long)]
        size: String,
        /// Grid m,n (touches along X and Y).
        #[arg(long)]
        grid: String,
        /// Stylus ball radius: the grid stays this far inside the rectangle's edges
        /// (default 0.0625 in or 1.5 mm, a 1/8-in or 3-mm ball).
        #[arg(long, allow_hyphen_values = true)]
        stylus_radius: Option<f64>,
        /// Height for moves between touches (default 10 clearances above the face).
        #[arg(long, allow_hyphen_values = true)]
        safe_z: Option<f64>,
        /// Program units.
        #[arg(long, value_enum, default_value = "inch")]
        units: UnitsArg,
        /// Program number.
        #[arg(long, default_value_t = 9501)]
        program_number: u32,
        /// Output file (atomic); standard output if absent.
        #[arg(short, long)]
        output: Option<String>,
    },
    /// Turn the controller's RS-232 log into a point file.
    Read {
        /// The log, or - for standard input.
        log: String,
        /// Output file (atomic); standard output if absent.
        #[arg(short, long)]
        output: Option<String>,
        /// Write JSON.
        #[arg(long)]
        json: bool,
    },
}

/// `lampost inspect` subcommands.
#[derive(Subcommand, Debug)]
enum InspectCmd {
    /// A measuring plan: for each point (x y z i j k, the outward normal) the machine position that puts the sensor's zero on it with the beam along the normal (Figure 7b's rows), ordered to keep rotary motion small; optionally the program that runs it.
    Plan {
        /// Built-in machine name or machine file.
        #[arg(long)]
        machine: String,
        /// Override a machine parameter (repeatable).
        #[arg(long = "set", value_name = "NAME=VALUE")]
        set: Vec<String>,
        /// The sensor head (default: the first head with a sensor).
        #[arg(long)]
        head: Option<String>,
        /// Sampling points with their outward normals: a point file with a header naming x y z i j k.
        #[arg(long, required_unless_present = "mesh", conflicts_with = "mesh")]
        points: Option<String>,
        /// Or sample the CAD mesh (STL, OBJ, OFF; in the machine's units unless --mesh-units) about --spacing apart, with its face normals.
        #[arg(long, requires = "spacing")]
        mesh: Option<String>,
        /// Distance between sampling points on the mesh (along each section with --sections).
        #[arg(long)]
        spacing: Option<f64>,
        /// Sample along section planes instead of over the whole mesh, as CMM software scans sections: AXIS=VALUES, values and start:stop:step ranges comma-separated (z=5,10,15 or x=0:100:10); repeatable.
        #[arg(long, value_name = "AXIS=VALUES", requires = "mesh")]
        sections: Vec<String>,
        /// The mesh file's units (default: the machine's).
        #[arg(long, value_enum)]
        mesh_units: Option<mesh_cmds::MeshUnits>,
        /// Largest tilt of the beam from a normal, degrees (at most the sensor's).
        #[arg(long)]
        max_tilt: Option<f64>,
        /// Plan the reachable points and list the others, rather than refusing.
        #[arg(long)]
        skip_unreachable: bool,
        /// Measure with a touch probe of this stylus-ball radius (the FADAL's) instead of a displacement sensor: a G31 probing program along the normals.
        #[arg(long)]
        stylus_radius: Option<f64>,
        /// Also write the measuring program (ISO) here.
        #[arg(long, value_name = "FILE.nc")]
        program: Option<String>,
        /// The plan file (atomic); standard output if absent.
        #[arg(short, long)]
        output: Option<String>,
    },
    /// Readings (a log of `id r`) back to workpiece coordinates through the plan's machine positions; each point's deviation along its normal; out-of-range and missing readings flagged.
    Reduce {
        /// The plan file `inspect plan` wrote.
        #[arg(long)]
        plan: String,
        /// The sensor's log: `id r` per line.
        log: String,
        /// Built-in machine name or machine file.
        #[arg(long)]
        machine: String,
        /// Override a machine parameter (repeatable).
        #[arg(long = "set", value_name = "NAME=VALUE")]
        set: Vec<String>,
        /// The sensor head (default: the first head with a sensor).
        #[arg(long)]
        head: Option<String>,
        /// Output file (atomic); standard output if absent.
        #[arg(short, long)]
        output: Option<String>,
        /// Write JSON.
        #[arg(long)]
        json: bool,
    },
    /// What the plan's sensor would read on an "actual" mesh: the beam cast over its range, a tilt-dependent bias, Gaussian noise (seeded), no reading beyond the range; a log `inspect reduce` reads.
    Simulate {
        /// The plan file `inspect plan` wrote.
        #[arg(long)]
        plan: String,
        /// The actual part (STL, OBJ, OFF; the machine's units unless --mesh-units).
        #[arg(long)]
        mesh: String,
        /// The mesh file's units (default: the machine's).
        #[arg(long, value_enum)]
        mesh_units: Option<mesh_cmds::MeshUnits>,
        /// Built-in machine name or machine file.
        #[arg(long)]
        machine: String,
        /// Override a machine parameter (repeatable).
        #[arg(long = "set", value_name = "NAME=VALUE")]
        set: Vec<String>,
        /// The sensor head (default: the first head with a sensor).
        #[arg(long)]
        head: Option<String>,
        /// Standard deviation of the reading noise.
        #[arg(long, default_value_t = 0.0)]
        noise: f64,
        /// Seed of the noise.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// The log (atomic); standard output if absent.
        #[arg(short, long)]
        output: Option<String>,
    },
    /// Deviation statistics of a reduced file (mean, sd, rms, min, max, percentiles, share within ±tol).
    Compare {
        /// The file `inspect reduce` wrote.
        measured: String,
        #[command(flatten)]
        args: inspect_cmds::CompareArgs,
    },
    /// Closing the loop for deposition: the measured points out of tolerance (material missing or in excess), each with the posted program's line and layer that deposited nearest to it within --radius.
    Deposits {
        /// The file `inspect reduce` wrote.
        measured: String,
        /// The posted deposition program the part was built with.
        #[arg(long)]
        posted: String,
        /// Built-in machine name or machine file.
        #[arg(long)]
        machine: String,
        /// Override a machine parameter (repeatable).
        #[arg(long = "set", value_name = "NAME=VALUE")]
        set: Vec<String>,
        /// The deposition head (default: `laser`).
        #[arg(long)]
        head: Option<String>,
        /// Tolerance ± (machine units): beyond it material is missing or in excess.
        #[arg(long)]
        tol: f64,
        /// How far from a point a deposition move may be to have deposited there.
        #[arg(long)]
        radius: f64,
        /// Output file (atomic); standard output if absent.
        #[arg(short, long)]
        output: Option<String>,
        /// Write JSON.
        #[arg(long)]
        json: bool,
    },
}

#[derive(Subcommand, Debug)]
enum MeshCmd {
    /// Triangles, welded vertices, bounds, area, volume, and the bad edges of the manifold report.
    Info {
        /// The mesh (STL, OBJ or OFF).
        file: String,
        /// The file's units (default mm); the figures are in mm.
        #[arg(long, value_enum)]
        units: Option<mesh_cmds::MeshUnits>,
        /// Write JSON.
        #[arg(long)]
        json: bool,
    },
}

#[derive(Subcommand, Debug)]
enum PlanCmd {
    /// Slice a mesh into closed oriented loops: planes normal to a build direction, or a fan about an axis.
    Slice(mesh_cmds::SliceArgs),
    /// Paper 001's plan per layer: perimeters with their tool axes (the surface normal × the traversal, blended across face edges), then rasters clipped to the inset loops; the offset-angle check (tilting where needed); the per-point path `lampost post` reads, a JSON report, an SVG preview.
    Path(Box<plan_cmds::PathArgs>),
    /// Paper 001's demonstration part: a 600 × 200 mm rectangle twisted 90° about a long edge, as a closed thin-walled STL (scaled with --scale).
    Demo(plan_cmds::DemoArgs),
}

#[derive(Subcommand, Debug)]
// Parsed once per run: the size of the largest subcommand's options costs nothing.
#[allow(clippy::large_enum_variant)]
enum Command {
    /// Triangle meshes (STL, OBJ, OFF): measures and the closed-manifold report.
    Mesh {
        #[command(subcommand)]
        cmd: MeshCmd,
    },
    /// Deposition planning from a solid mesh (paper 001): slicing, the whole plan, the demo part.
    Plan {
        #[command(subcommand)]
        cmd: PlanCmd,
    },
    /// Post a planar toolpath into a 5-axis deposition or machining program.
    Post {
        /// The planar program (or - for standard input); not with --job.
        input: Option<String>,
        #[command(flatten)]
        args: post_cmds::PostArgs,
        /// Output file (written to a temporary file, verified, then renamed); standard output if absent.
        #[arg(short, long)]
        output: Option<String>,
        /// Split into pieces of at most this many bytes (FADAL: subprograms; others: numbered files).
        #[arg(long)]
        max_bytes: Option<usize>,
        /// Write a JSON report (moves, warnings, limits used, verification, time) to this file.
        #[arg(long)]
        json_report: Option<String>,
    },
    /// In-line measurement with the machine's displacement sensor (paper 003): plan, reduce, compare.
    Inspect {
        #[command(subcommand)]
        cmd: InspectCmd,
    },
    /// Draw a posted program as SVG: the toolpath in the part frame, one colour per index, rapids dashed, the machine's travel at each index.
    Preview {
        /// The posted program (several files: the DNC pieces of a split program, in order).
        #[arg(num_args = 1.., required = true)]
        posted: Vec<String>,
        /// Built-in machine name or machine file.
        #[arg(long)]
        machine: String,
        /// Head (default: laser for deposit, spindle for machine).
        #[arg(long)]
        head: Option<String>,
        /// deposit or machine (chooses the default head; solid lines are deposition or cutting).
        #[arg(long, default_value = "deposit")]
        process: String,
        /// Override a machine parameter (repeatable).
        #[arg(long = "set", value_name = "NAME=VALUE")]
        set: Vec<String>,
        /// top (part XY) or iso.
        #[arg(long, default_value = "top", value_name = "top|iso")]
        view: String,
        /// The SVG file (atomic).
        #[arg(short, long)]
        output: String,
    },
    /// Replay a posted program through forward kinematics and compare it with the intended path.
    Verify {
        /// INPUT POSTED...: the planar program and the posted program (with --job, POSTED
        /// alone). Several POSTED files are the DNC pieces of a split program, in order.
        #[arg(num_args = 1.., required = true)]
        files: Vec<String>,
        /// Built-in machine name or machine file.
        #[arg(long)]
        machine: String,
        #[command(flatten)]
        place: post_cmds::Placement,
        /// Head (default: laser for deposit, spindle for machine).
        #[arg(long)]
        head: Option<String>,
        /// The process options the program was posted with, as `post` takes them (the
        /// process chooses the default head): every move must be in its work offset,
        /// under its length offset and tool, at its laser power or spindle speed.
        #[command(flatten)]
        proc: post_cmds::ProcessArgs,
        /// Override a machine parameter (repeatable).
        #[arg(long = "set", value_name = "NAME=VALUE")]
        set: Vec<String>,
        /// Largest allowed distance from the intended path (default 0.001 in / 0.02 mm;
        /// for an arm, its file's `[cell]` tolerance).
        #[arg(long)]
        tolerance: Option<f64>,
        /// Arms: the path the folder was posted from (`verify --machine ARM DIR --input PATH`).
        #[arg(long)]
        input: Option<String>,
        /// Write JSON.
        #[arg(long)]
        json: bool,
        /// Also draw the posted path as SVG, each feed coloured by its deviation from
        /// the intended path (green 0, red at the tolerance). Written also when the
        /// check fails, up to where it stopped.
        #[arg(long, value_name = "FILE.svg")]
        preview: Option<String>,
        /// The preview's view: top (part XY) or iso.
        #[arg(long, default_value = "top")]
        view: String,
    },
    /// Calibrate the rotary centre (R), the axis lines, and the laser offset (L).
    Calibrate {
        #[command(subcommand)]
        cmd: CalibrateCmd,
    },
    /// FADAL probing programs, and reading their logs.
    Probe {
        #[command(subcommand)]
        cmd: ProbeCmd,
    },
    /// Levelling and CAD alignment.
    Align {
        #[command(subcommand)]
        cmd: AlignCmd,
    },
    /// Fit a sphere, plane or circle to probed points (x y z per line, or a NIST .ds file).
    Fit {
        /// What to fit.
        #[arg(value_enum)]
        kind: align_cmds::FitKind,
        /// Point file, or - for standard input.
        file: String,
        /// Sphere: fix the radius (stylus-centre points on a gage ball: ball + stylus radius).
        #[arg(long, allow_hyphen_values = true)]
        radius: Option<f64>,
        /// Sphere: the gage ball's radius, to report the effective probe radius.
        #[arg(long, allow_hyphen_values = true)]
        ball_radius: Option<f64>,
        /// Expected probe noise (one sigma, in the points' units): warn when the rms
        /// residual exceeds three times it.
        #[arg(long, allow_hyphen_values = true)]
        noise: Option<f64>,
        /// Write JSON.
        #[arg(long)]
        json: bool,
    },
    /// List the built-in machines, or print one with `show NAME`.
    Machines {
        #[command(subcommand)]
        cmd: Option<MachinesCmd>,
    },
    /// Machine kinematics: fk, ik, rotate.
    Kin {
        #[command(subcommand)]
        cmd: KinCmd,
    },
    /// Check a program: every problem with file:line:col, the line, a caret and a hint.
    Check {
        /// Program file, or - for standard input.
        file: String,
        /// Report as JSON, streamed: the first 10,000 diagnostics, then a count of the rest.
        #[arg(long)]
        json: bool,
        #[command(flatten)]
        interp: InterpArgs,
    },
    /// Rewrite a program: verbatim numbers, or a dialect's format; optional renumbering.
    Fmt {
        /// Program file, or - for standard input.
        file: String,
        /// Output file (written atomically); standard output if absent.
        #[arg(short, long)]
        output: Option<String>,
        /// Rewrite numbers in this dialect's format (default: keep every digit).
        #[arg(long, value_enum)]
        dialect: Option<DialectArg>,
        /// Renumber blocks: START,STEP (e.g. 10,10).
        #[arg(long, value_name = "START,STEP")]
        renumber: Option<String>,
        /// Leave out repeated motion G-codes and feed rates.
        #[arg(long)]
        suppress_modal: bool,
        /// Units before the program's first G20/G21 (decides a dialect's decimals; with
        /// --dialect and a program that says none before its first coordinate, required).
        #[arg(long, value_enum)]
        units: Option<UnitsArg>,
        /// The control the program was written for (marlin and reprap read number exponents).
        #[arg(long, value_enum, default_value = "auto")]
        flavor: FlavorArg,
    },
    /// Show the interpreted motion: one line per move, absolute, in program units.
    Trace {
        /// Program file, or - for standard input.
        file: String,
        /// Output file; standard output if absent.
        #[arg(short, long)]
        output: Option<String>,
        /// Write JSON: {"moves": […], "diagnostics": […]}.
        #[arg(long)]
        json: bool,
        #[command(flatten)]
        interp: InterpArgs,
    },
    /// Print a shell completion script (e.g. `lampost completions bash > /etc/bash_completion.d/lampost`).
    Completions {
        /// The shell.
        shell: ShellArg,
    },
    /// Write the manual pages (roff): `lampost.1` and one page per subcommand.
    Man {
        /// Directory to write them into (created if missing).
        #[arg(long, default_value = "man")]
        out_dir: String,
    },
}

/// Shells for `lampost completions`.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum ShellArg {
    /// Bash.
    Bash,
    /// Zsh.
    Zsh,
    /// Fish.
    Fish,
    /// PowerShell.
    Powershell,
    /// Elvish.
    Elvish,
}

fn run(cli: Cli) -> Result<(), CliError> {
    match cli.command {
        Command::Post {
            input,
            args,
            output,
            max_bytes,
            json_report,
        } => post_cmds::post(
            &args,
            input.as_deref(),
            output.as_deref(),
            max_bytes,
            json_report.as_deref(),
        ),
        Command::Inspect {
            cmd:
                InspectCmd::Plan {
                    machine,
                    set,
                    head,
                    points,
                    mesh,
                    spacing,
                    mesh_units,
                    sections,
                    max_tilt,
                    skip_unreachable,
                    stylus_radius,
                    program,
                    output,
                },
        } => inspect_cmds::plan_cmd(
            &machine,
            &set,
            head.as_deref(),
            &inspect_cmds::Sampling {
                points,
                mesh,
                spacing,
                mesh_units,
                sections,
            },
            max_tilt,
            output.as_deref(),
            program.as_deref(),
            skip_unreachable,
            stylus_radius,
        ),
        Command::Inspect {
            cmd:
                InspectCmd::Reduce {
                    plan,
                    log,
                    machine,
                    set,
                    head,
                    output,
                    json,
                },
        } => inspect_cmds::reduce_cmd(
            &machine,
            &set,
            head.as_deref(),
            &plan,
            &log,
            output.as_deref(),
            json,
        ),
        Command::Inspect {
            cmd:
                InspectCmd::Simulate {
                    plan,
                    mesh,
                    mesh_units,
                    machine,
                    set,
                    head,
                    noise,
                    seed,
                    output,
                },
        } => inspect_cmds::simulate_cmd(
            &machine,
            &set,
            head.as_deref(),
            &plan,
            &mesh,
            mesh_units,
            noise,
            seed,
            output.as_deref(),
        ),
        Command::Inspect {
            cmd: InspectCmd::Compare { measured, args },
        } => inspect_cmds::compare_cmd(&measured, &args),
        Command::Inspect {
            cmd:
                InspectCmd::Deposits {
                    measured,
                    posted,
                    machine,
                    set,
                    head,
                    tol,
                    radius,
                    output,
                    json,
                },
        } => inspect_cmds::deposits_cmd(
            &machine,
            &set,
            head.as_deref(),
            &posted,
            &measured,
            tol,
            radius,
            output.as_deref(),
            json,
        ),
        Command::Preview {
            posted,
            machine,
            head,
            process,
            set,
            view,
            output,
        } => post_cmds::preview(
            &machine,
            &set,
            head.as_deref(),
            &process,
            &posted,
            &output,
            &view,
        ),
        Command::Verify {
            files,
            machine,
            place,
            head,
            proc,
            set,
            tolerance,
            input,
            json,
            preview,
            view,
        } => {
            if let Some(arm) = robot_cmds::arm_for(&machine)? {
                if let Some(flag) = proc.machining_options().first() {
                    return Err(CliError::usage(format!(
                        "error: {flag} is for table machines' programs; {} is an arm\n",
                        arm.name
                    )));
                }
                if preview.is_some() {
                    return Err(CliError::usage(format!(
                        "error: --preview draws table machines' programs; {} is an arm\n",
                        arm.name
                    )));
                }
                if !set.is_empty() || head.is_some() {
                    return Err(CliError::usage(format!(
                        "error: --set and --head are for table machines; {} is an arm (its settings are in its file)\n",
                        arm.name
                    )));
                }
                let (path, dir) = match (files.as_slice(), input.as_deref()) {
                    ([dir], Some(p)) => (p.to_string(), dir.clone()),
                    ([p, dir], None) => (p.clone(), dir.clone()),
                    _ => {
                        return Err(CliError::usage(
                            "error: give the output folder and the path: verify --machine ARM DIR --input PATH\n".to_string(),
                        ))
                    }
                };
                return robot_cmds::verify(&arm, &place, &path, &dir, tolerance, json);
            }
            if input.is_some() {
                return Err(CliError::usage(
                    "error: --input is for arm output; for a program give INPUT POSTED\n"
                        .to_string(),
                ));
            }
            let (input, posted) = match files.as_slice() {
                [p] => (None, vec![p.clone()]),
                all if place.job.is_some() => (None, all.to_vec()),
                [i, p @ ..] => (Some(i.clone()), p.to_vec()),
                [] => {
                    return Err(CliError::usage(
                        "error: give INPUT POSTED (or POSTED with --job)\n".to_string(),
                    ))
                }
            };
            post_cmds::verify(
                &machine,
                &set,
                &place,
                head.as_deref(),
                &proc,
                input.as_deref(),
                &posted,
                tolerance,
                json,
                preview.as_deref(),
                &view,
            )
        }
        Command::Calibrate {
            cmd:
                CalibrateCmd::Pivot {
                    poses,
                    ball,
                    method,
                    write,
                    m,
                },
        } => calib_cmds::pivot(
            &m.machine,
            &m.set,
            &poses,
            &ball.size(),
            method.as_deref(),
            write.as_deref(),
            m.json,
        ),
        Command::Calibrate {
            cmd: CalibrateCmd::Axes { poses, ball, m },
        } => calib_cmds::axes(&m.machine, &m.set, &poses, &ball.size(), m.json),
        Command::Calibrate {
            cmd:
                CalibrateCmd::Factorial {
                    start,
                    step,
                    fit,
                    json,
                },
        } => calib_cmds::factorial(start.as_deref(), step, fit.as_deref(), json),
        Command::Calibrate {
            cmd:
                CalibrateCmd::Laser {
                    burned,
                    probed,
                    file,
                    json,
                },
        } => calib_cmds::laser(&burned, &probed, file.as_deref(), json),
        Command::Probe {
            cmd:
                ProbeCmd::Poses {
                    machine,
                    set,
                    ball,
                    poses,
                    for_,
                    radius,
                    stylus_radius,
                    points,
                    output,
                },
        } => calib_cmds::probe_poses(
            &machine,
            &set,
            &ball,
            poses.as_deref(),
            &for_,
            radius,
            stylus_radius,
            points,
            output.as_deref(),
        ),
        Command::Probe {
            cmd:
                ProbeCmd::Sphere {
                    center,
                    radius,
                    stylus_radius,
                    points,
                    cap_deg,
                    units,
                    program_number,
                    output,
                },
        } => align_cmds::probe_sphere(
            &center,
            radius,
            stylus_radius,
            points,
            cap_deg,
            units,
            program_number,
            output.as_deref(),
        ),
        Command::Probe {
            cmd:
                ProbeCmd::Plane {
                    corner,
                    size,
                    grid,
                    stylus_radius,
                    safe_z,
                    units,
                    program_number,
                    output,
                },
        } => align_cmds::probe_plane(
            &align_cmds::PlaneGrid {
                corner: &corner,
                size: &size,
                grid: &grid,
                stylus_radius,
            },
            safe_z,
            units,
            program_number,
            output.as_deref(),
        ),
        Command::Probe {
            cmd: ProbeCmd::Read { log, output, json },
        } => align_cmds::probe_read(&log, output.as_deref(), json),
        Command::Align {
            cmd:
                AlignCmd::Register {
                    file,
                    mesh,
                    lock,
                    write_setup,
                    json,
                },
        } => align_cmds::register(&file, &mesh, lock.as_deref(), write_setup.as_deref(), json),
        Command::Align {
            cmd:
                AlignCmd::Level {
                    file,
                    machine,
                    near,
                    outward,
                    set,
                    json,
                },
        } => align_cmds::level(
            &file,
            &machine,
            &set,
            near.as_deref(),
            outward.as_deref(),
            json,
        ),
        Command::Align {
            cmd:
                AlignCmd::Angle {
                    file,
                    to_normal,
                    to_plane,
                    origin,
                    write_setup,
                    json,
                },
        } => align_cmds::angle(
            &file,
            to_normal.as_deref(),
            to_plane.as_deref(),
            origin.as_deref(),
            write_setup.as_deref(),
            json,
        ),
        Command::Fit {
            kind,
            file,
            radius,
            ball_radius,
            noise,
            json,
        } => align_cmds::fit(kind, &file, radius, ball_radius, noise, json),
        Command::Mesh {
            cmd: MeshCmd::Info { file, units, json },
        } => mesh_cmds::info(&file, units, json),
        Command::Plan {
            cmd: PlanCmd::Slice(a),
        } => mesh_cmds::slice(&a),
        Command::Plan {
            cmd: PlanCmd::Path(a),
        } => plan_cmds::path(&a),
        Command::Plan {
            cmd: PlanCmd::Demo(a),
        } => plan_cmds::demo(&a),
        Command::Machines { cmd: None } => kin_cmds::machines(None),
        Command::Machines {
            cmd: Some(MachinesCmd::Show { name }),
        } => kin_cmds::machines(Some(&name)),
        Command::Kin {
            cmd: KinCmd::Fk { joints, m },
        } => kin_cmds::fk(&m.machine, &joints, m.head.as_deref(), &m.set, m.json),
        Command::Kin {
            cmd:
                KinCmd::Ik {
                    position,
                    axis,
                    points,
                    near,
                    m,
                },
        } => match (points, position, axis) {
            (Some(file), _, _) => kin_cmds::ik_points(
                &m.machine,
                &file,
                m.head.as_deref(),
                near.as_deref(),
                &m.set,
                m.json,
            ),
            (None, Some(position), Some(axis)) => kin_cmds::ik(
                &m.machine,
                &position,
                &axis,
                m.head.as_deref(),
                near.as_deref(),
                &m.set,
                m.json,
            ),
            _ => Err(report::CliError::usage(
                "error: give --position and --axis, or --points FILE\n".to_string(),
            )),
        },
        Command::Kin {
            cmd: KinCmd::Rotate { joints, file, m },
        } => kin_cmds::rotate(
            &m.machine,
            &joints,
            m.head.as_deref(),
            &m.set,
            &file,
            m.json,
        ),
        Command::Check { file, json, interp } => gcode_cmds::check(&file, json, interp),
        Command::Fmt {
            file,
            output,
            dialect,
            renumber,
            suppress_modal,
            units,
            flavor,
        } => gcode_cmds::fmt(
            &file,
            output.as_deref(),
            dialect,
            renumber.as_deref(),
            suppress_modal,
            (units, flavor),
        ),
        Command::Trace {
            file,
            output,
            json,
            interp,
        } => gcode_cmds::trace(&file, output.as_deref(), json, interp),
        Command::Completions { shell } => docs::completions(shell),
        Command::Man { out_dir } => docs::man(&out_dir),
    }
}

fn main() {
    let cli = Cli::parse();
    io::remove_temps_on_signal();
    if let Err(e) = run(cli) {
        if e.code == report::QUIET_EXIT {
            // The reader of our output went away (e.g. `| head`): stop quietly.
            std::process::exit(0);
        }
        if !e.message.is_empty() {
            eprint!("{}", e.message);
            if !e.message.ends_with('\n') {
                eprintln!();
            }
        }
        std::process::exit(e.code);
    }
}
