//! Programs in another language than G-code: a line that does not read as G-code is
//! checked against the shapes of the languages CAM systems and robot controllers also
//! write, so the error names the language instead of a stray letter (`the letter T has no
//! number after it` on a Sinumerik `T="MILL_10"`).

/// A language that is not G-code, and what to do about it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Foreign {
    /// The language, as the message names it.
    pub name: &'static str,
    /// What the user can do.
    pub hint: &'static str,
}

const HEIDENHAIN: Foreign = Foreign {
    name: "Heidenhain conversational (Klartext)",
    hint: "post the job from the CAM system for an ISO G-code control (Fanuc, LinuxCNC or FADAL); lampost reads no Klartext",
};
const SINUMERIK: Foreign = Foreign {
    name: "Siemens Sinumerik syntax",
    hint: "post the job for an ISO G-code control (Fanuc, LinuxCNC or FADAL), without Sinumerik cycles, `NAME=` values and `T=\"…\"` tools",
};
const OKUMA: Foreign = Foreign {
    name: "Okuma OSP syntax (`VC` variables, `IF [VC1 EQ 20] NLABEL` branches, named labels)",
    hint: "post the job from the CAM system for an ISO G-code control (Fanuc, LinuxCNC or FADAL); lampost reads no OSP user task statements",
};
const APT: Foreign = Foreign {
    name: "APT cutter-location (CL) data, a CAM system's output before posting",
    hint: "post the CL file in the CAM system for a G-code control, then give lampost the G-code",
};
const CENTROID: Foreign = Foreign {
    name: "Centroid CNC12 macro syntax (C-style conditions: `IF #4201 || #4202 THEN GOTO 1000`)",
    hint: "post the job for an ISO G-code control; lampost does not run Centroid's macro statements (the job's own moves read as G-code once they are left out)",
};
const EDING: Foreign = Foreign {
    name: "Eding CNC macro syntax (`sub`/`endsub`, `gosub`, `msg \"…\"`, `IF [#5398 == 1]` … `ENDIF`)",
    hint: "this is a controller's macro file (macro.cnc), not a job: post the job for an ISO G-code control; lampost does not run Eding CNC's macro statements",
};
const SLASH_COMMENT: Foreign = Foreign {
    name: "a `//` comment (DDCS, Syntec, LNC and MillMaster Pro controls read them; G-code comments are `( … )` and `;`)",
    hint: "write the comment in `( … )` or after `;`, or post the job for an ISO G-code control; lampost does not run these controllers' macro statements",
};
const DDCS: Foreign = Foreign {
    name: "DDCS controller macro syntax (C-style conditions with a GOTO and no THEN: `IF #1505==1 GOTO20`)",
    hint: "post the job for an ISO G-code control; lampost does not run the DDCS controller's macro statements",
};
const SHOPBOT: Foreign = Foreign {
    name: "ShopBot OpenSBP (two-letter commands and comma-separated values)",
    hint: "post the job from the CAM system for a G-code control (Vectric and Fusion have G-code posts for ShopBot's and other routers); lampost reads no OpenSBP",
};
/// What to do with a robot program.
/// PrusaSlicer's binary G-code (libbgcode's `.bgcode`: the file starts with the magic
/// `GCDE`, then compressed blocks).
pub(crate) const BINARY_GCODE: Foreign = Foreign {
    name: "binary G-code (PrusaSlicer's .bgcode)",
    hint: "export plain-text G-code from the slicer (PrusaSlicer: Printer Settings → General → Firmware, `Supports binary G-code` off), or convert the file to text with libbgcode's bgcode tool",
};

const ROBOT_HINT: &str =
    "give lampost the path (a G-code program or a per-point CSV), not a robot program";
const KRL: Foreign = Foreign {
    name: "KUKA robot language (KRL)",
    hint: ROBOT_HINT,
};
const RAPID: Foreign = Foreign {
    name: "ABB RAPID",
    hint: ROBOT_HINT,
};
const FANUC_TP: Foreign = Foreign {
    name: "a FANUC robot teach-pendant program",
    hint: ROBOT_HINT,
};

/// The language `line` is written in, when it has the shape of a line of a language
/// other than G-code (only asked of lines that do not read as G-code).
pub fn foreign_language(line: &str) -> Option<Foreign> {
    let t = line.trim();
    let upper = t.to_ascii_uppercase();
    let u = upper.as_str();
    // Heidenhain: every block starts with its number and a space, then a keyword.
    let digits = u.bytes().take_while(u8::is_ascii_digit).count();
    if digits > 0 && u[digits..].starts_with(' ') {
        let rest = u[digits..].trim_start();
        const KEYS: [&str; 18] = [
            "BEGIN PGM",
            "END PGM",
            "BLK FORM",
            "TOOL CALL",
            "TOOL DEF",
            "CYCL DEF",
            "CYCL CALL",
            "LBL ",
            "CALL LBL",
            "CALL PGM",
            "FN ",
            "L ",
            "LP ",
            "CC ",
            "CR ",
            "CT ",
            "APPR",
            "DEP",
        ];
        if KEYS.iter().any(|k| rest.starts_with(k)) {
            return Some(HEIDENHAIN);
        }
    }
    if u.starts_with("BEGIN PGM") || u.starts_with("END PGM") {
        return Some(HEIDENHAIN);
    }
    // APT: a major word and a slash (`GOTO/1.0,2.0,3.0`, `FEDRAT/500`), or one of the
    // words that stand alone.
    let word: &str = u.split([' ', '/', ',']).next().unwrap_or("");
    if word.len() >= 4
        && word.bytes().all(|c| c.is_ascii_uppercase())
        && u[word.len()..].trim_start().starts_with('/')
        || matches!(u, "RAPID" | "FINI" | "END")
        || u.starts_with("PARTNO")
    {
        return Some(APT);
    }
    // Robot languages.
    if u.starts_with("&ACCESS")
        || u.starts_with("&REL")
        || u.starts_with("$VEL")
        || u.starts_with("$APO")
        || u.starts_with("BAS(")
        || ["PTP ", "LIN ", "CIRC ", "PTP_REL ", "LIN_REL "]
            .iter()
            .any(|k| u.starts_with(k))
        || u.starts_with("DEF ") && u.contains("()")
        || u.contains("{X ")
        || u.contains("{A1 ")
    {
        return Some(KRL);
    }
    if [
        "MODULE ",
        "ENDMODULE",
        "PROC ",
        "ENDPROC",
        "MOVEL ",
        "MOVEJ ",
        "MOVEC ",
        "MOVEABSJ ",
    ]
    .iter()
    .any(|k| u.starts_with(k))
        || u.contains("ROBTARGET")
    {
        return Some(RAPID);
    }
    if u.starts_with("/PROG")
        || u.starts_with("/MN")
        || u.starts_with("/POS")
        || u.starts_with("/ATTR")
    {
        return Some(FANUC_TP);
    }
    // ShopBot OpenSBP: a two-letter command, then its values after commas (`MS,2,2`,
    // `J3,1.2,1.1,0.2`, `CG, ,1.2,…`), or the absolute and relative mode words alone.
    // (No G-code line starts with a letter, a letter or digit, and a comma.)
    // Its comments start with `'`; its conditions read system values `%(25)`.
    let sbp = u.split('\'').next().unwrap_or("").trim();
    let b = sbp.as_bytes();
    if b.len() >= 3 && b[0].is_ascii_uppercase() && b[1].is_ascii_alphanumeric() && b[2] == b','
        || matches!(sbp, "SA" | "SR")
        || sbp.starts_with("IF %(")
        || sbp.contains(" THEN GOSUB ")
    {
        return Some(SHOPBOT);
    }
    // Eding CNC's macro files (macro.cnc): subroutines by name (`sub home_z`, `endsub`,
    // `gosub home_x`), messages and dialogs in double quotes (`msg "…"`, `dlgmsg "…"`),
    // and a block `IF [#5398 == 1]` with C's operators and no THEN (closed by `ENDIF`).
    let code = u.split(['(', ';']).next().unwrap_or("").trim();
    let first = code.split_whitespace().next().unwrap_or("");
    let c_operator = |s: &str| {
        ["||", "&&", "==", "!=", "<", ">"]
            .iter()
            .any(|k| s.contains(k))
    };
    let then = code.split_whitespace().any(|w| w == "THEN");
    let goto = code.split_whitespace().any(|w| w.starts_with("GOTO"));
    let eding_word = match first {
        "SUB" | "GOSUB" => code.split_whitespace().nth(1).is_some_and(|n| {
            n.bytes()
                .next()
                .is_some_and(|c| c.is_ascii_alphabetic() || c == b'_')
        }),
        "ENDSUB" => code == "ENDSUB",
        "MSG" | "DLGMSG" | "WARNMSG" | "ERRMSG" => {
            code[first.len()..].trim_start().starts_with('"')
        }
        _ => false,
    };
    if eding_word || code.starts_with("IF [") && c_operator(code) && !then && !goto {
        return Some(EDING);
    }
    // `//` comments: DDCS (Digital Dream), Syntec and LNC macros (`#20=1 //Beginning X`,
    // `//Macro author …` on a line of its own) and MillMaster Pro programs. No G-code
    // writes `//` outside a comment (one `/` is the block delete).
    // DDCS's jumps on C-style conditions without THEN (`IF #1505==1 GOTO20`,
    // `IF [#14==5]+[#14==4] GOTO10`).
    if code.contains("//") {
        return Some(SLASH_COMMENT);
    }
    if first == "IF" && c_operator(code) && goto && !then && code.contains('#') {
        return Some(DDCS);
    }
    // Centroid CNC12: a condition on a bare variable (`IF #50010`, which stops its
    // look-ahead) or with C's operators (`IF #4201 || #4202 THEN GOTO 1000`); Fanuc's
    // and LinuxCNC's conditions are bracketed and spell EQ, AND, OR.
    // RepRapFirmware's meta commands (`if state.currentTool != -1`) are lower case and
    // name the object model, not `#` variables.
    if t.starts_with("IF #")
        || t.starts_with("IF")
            && t.contains('#')
            && ["||", "&&", "==", "!="].iter().any(|k| t.contains(k))
    {
        return Some(CENTROID);
    }
    // Okuma OSP: user task variables (`VC1=20`, `IF [VC1 EQ 20] NDTM8`), a branch to a
    // named label (`GOTO NLOOP`), the file's header (`$O0137.MIN%`, `$OKUMA.SSB%`).
    let words: Vec<&str> = u.split_whitespace().collect();
    let vc = |w: &str| {
        w.strip_prefix("VC")
            .is_some_and(|r| r.bytes().next().is_some_and(|c| c.is_ascii_digit()))
    };
    if words.iter().any(|w| vc(w) && w.contains('='))
        || u.starts_with("IF [VC")
        || u.starts_with('$') && u.contains('.') && u.ends_with('%')
        || words.windows(2).any(|w| {
            w[0] == "GOTO"
                && w[1].len() > 1
                && w[1].starts_with('N')
                && w[1][1..]
                    .bytes()
                    .next()
                    .is_some_and(|c| c.is_ascii_uppercase())
        })
    {
        return Some(OKUMA);
    }
    // Sinumerik: its cycles, messages, tool names, `NAME=` values, R parameters
    // (`R20=200`, `R101=R101+1`) and frame statements.
    // Read without ISO comments: a Fusion or HSM tool comment says `CR=0.` (the corner
    // radius) in parentheses.
    let code = without_comments(u.split(';').next().unwrap_or(""));
    let code = code.as_str();
    let r_parameter = code.split_whitespace().any(|w| {
        w.strip_prefix('R').is_some_and(|r| {
            let d = r.bytes().take_while(u8::is_ascii_digit).count();
            d > 0 && r[d..].starts_with('=')
        })
    });
    if r_parameter {
        return Some(SINUMERIK);
    }
    const SIN: [&str; 24] = [
        "CYCLE", "MSG(", "MSG (", "T=\"", "=AC(", "=IC(", "=DC(", "=ACP(", "=ACN(", "CR=", "AP=",
        "RP=", "TURN=", "SUPA", "TRANS", "AROT", "TRAORI", "ORIWKS", "CFTCP", "GOTOF", "GOTOB",
        "MCALL", "STOPRE", "SPOS=",
    ];
    if SIN.iter().any(|k| code.contains(k))
        || code.starts_with("DEF REAL")
        || code.starts_with("DEF INT")
    {
        return Some(SINUMERIK);
    }
    None
}

/// `s` without its parenthesised comments: a `(` at the start or after a blank opens
/// one, to its `)` (or the end), except Sinumerik's `MSG (`; a `(` right after a name or
/// `=` is Sinumerik's call or value (`CYCLE81(`, `MSG(`, `=AC(`) and is kept.
fn without_comments(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    let mut rest = s;
    while let Some(k) = rest.find('(') {
        let before = &rest[..k];
        let attached = before.chars().last().is_some_and(|c| !c.is_whitespace());
        let message = before.trim_end().ends_with("MSG");
        out.push_str(before);
        if attached || message {
            out.push('(');
            rest = &rest[k + 1..];
        } else {
            rest = rest[k..].find(')').map_or("", |e| &rest[k + e + 1..]);
            out.push(' ');
        }
    }
    out.push_str(rest);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn languages_are_named() {
        for (line, want) in [
            ("0 BEGIN PGM 1001 MM", Some(HEIDENHAIN)),
            ("12 L X+10 Y+5 R0 FMAX M3", Some(HEIDENHAIN)),
            ("3 TOOL CALL 1 Z S3000", Some(HEIDENHAIN)),
            ("N20 T=\"MILL_10\" D1", Some(SINUMERIK)),
            ("N70 G2 X10 Y0 CR=5", Some(SINUMERIK)),
            // h61: a Fusion/HSM tool comment names the corner radius.
            ("(T2 D=1.587 CR=0. - ZMIN=-8.427 - FLAT END MILL)", None),
            ("G0 X1 (R1=5 CR=2)", None),
            ("MSG (\"ROUGHING\")", Some(SINUMERIK)),
            ("N10 G0 X=AC(10)", Some(SINUMERIK)),
            ("N80 CYCLE81(10,0,1,-5)", Some(SINUMERIK)),
            ("MSG(\"ROUGHING\")", Some(SINUMERIK)),
            ("GOTO/ 1.0000, 2.0000, 3.0000", Some(APT)),
            ("FEDRAT/MMPM,500.0", Some(APT)),
            ("RAPID", Some(APT)),
            ("PTP {A1 0,A2 -90,A3 90,A4 0,A5 0,A6 0}", Some(KRL)),
            ("LIN {X 100,Y 0,Z 50} C_DIS", Some(KRL)),
            ("&ACCESS RVP", Some(KRL)),
            ("MoveL p10, v100, fine, tool0;", Some(RAPID)),
            ("MODULE MainModule", Some(RAPID)),
            ("/PROG  WELD1", Some(FANUC_TP)),
            ("MS,2.0,2.0", Some(SHOPBOT)),
            ("J3,1.239209,1.139149,0.200000", Some(SHOPBOT)),
            ("CG, ,1.2,2.1,-1.0,0.0,T,-1", Some(SHOPBOT)),
            ("SA", Some(SHOPBOT)),
            ("IF #50010", Some(CENTROID)),
            ("IF #4201 || #4202 THEN GOTO 1000 ;Skip", Some(CENTROID)),
            ("IF [#1 EQ 2] GOTO 10", None),
            ("Sub zero_z", Some(EDING)),
            ("sub home_all ; HOMING", Some(EDING)),
            ("ENDSUB", Some(EDING)),
            ("    gosub home_z", Some(EDING)),
            ("msg \"Homing Z Axis\"", Some(EDING)),
            ("dlgmsg \"Reset G68 rotation offset?\"", Some(EDING)),
            (
                "\tIF [#3500 == 0]  ; IF [Initialize] is 0  proceed",
                Some(EDING),
            ),
            (
                "//Macros of cylindrical thread milling.",
                Some(SLASH_COMMENT),
            ),
            ("#20=1 //Beginning X coordinate", Some(SLASH_COMMENT)),
            ("//O0000Carriage-rail-hole", Some(SLASH_COMMENT)),
            ("IF #1505==1 GOTO20", Some(DDCS)),
            (
                "IF [#14==5]+[#14==4] GOTO10 ;;If the axis is incorrect",
                Some(DDCS),
            ),
            ("IF #1>0 GOTO1", Some(DDCS)),
            ("G0 X1 (http://example.com)", None),
            ("S1000 M3", None),
            ("M98 P1000", None),
            ("N1 R20=200", Some(SINUMERIK)),
            ("N6 R101=R101+1", Some(SINUMERIK)),
            ("VC1=20", Some(OKUMA)),
            ("IF [VC1 EQ 20] NDTM8", Some(OKUMA)),
            ("$O0137.MIN%", Some(OKUMA)),
            ("$OKUMA.SSB%", Some(OKUMA)),
            ("$$", None),
            ("$32=1", None),
            ("GOTO NLOOP", Some(OKUMA)),
            ("G2 X1 Y1 R2.5", None),
            ("G81 X1 Y1 Z-1 R0.1", None),
            ("#1=20", None),
            ("if state.currentTool != -1", None),
            ("if !move.axes[0].homed || !move.axes[1].homed", None),
            (
                "SA                             \t'Set program to absolute",
                Some(SHOPBOT),
            ),
            ("IF %(25)=1 THEN GOSUB UNIT_ERROR\t'check", Some(SHOPBOT)),
            ("G1 X1. ,R.1", None),
            // G-code lines with faults are not another language.
            ("G1 X", None),
            ("G0 X1 Y2 ; rapid", None),
            ("N10 G1 X1 Y", None),
            ("12 X1", None),
            ("SET_VELOCITY_LIMIT ACCEL=5000", None),
        ] {
            assert_eq!(foreign_language(line), want, "{line}");
        }
    }
}
