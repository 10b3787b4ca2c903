//! Keystroke-Level Model predictions (Card, Moran and Newell 1980; Kieras 2001).
//!
//! A method is a sequence of operators written in a small text format (see `docs/goms.md`
//! and [`parse_method`]):
//!
//! ```text
//! name: Point and double-click a file
//! H P B B B B      # hand to mouse, point, two clicks (press + release each)
//! ```
//!
//! The prediction is the sum of the operator times, `T = Σ n_op · t_op`, with the
//! standard constants ([`Constants`]): K 0.28 s (average non-secretary typist) or
//! 0.20 s (average skilled), B 0.10 s, P 1.10 s, H 0.40 s, M 1.35 s (Card, Moran and
//! Newell) or 1.20 s (Kieras), and `R(t)` system response times as written.
//!
//! [`place_mentals`] places the M operators by Card, Moran and Newell's heuristic
//! rules 0 to 4 (The Psychology of Human-Computer Interaction, 1983, fig. 8.2):
//! - **Rule 0**: an M before every K (and B) that is not part of an argument string, and
//!   before every P that selects a command (not an argument).
//! - **Rule 1**: delete an M whose operator is fully anticipated by the one before it
//!   (P then its click, a button press then its release), and the M before the P of a
//!   drag: B operators alternate press and release, and a P while the button is held
//!   is part of the press-sweep-release chunk (`P B P B` is `M P B P B`, Kieras 2001).
//! - **Rule 2**: in a cognitive unit (`{...}`, e.g. a command name), keep only the first M.
//! - **Rule 3**: delete the M before a redundant terminator (`K.rt`).
//! - **Rule 4**: delete the M before a terminator of a constant string (`K.tc`); keep it
//!   before a terminator of a variable string (`K.tv`).

use std::fmt;

/// Most steps a method may expand to (repetitions included).
pub const MAX_STEPS: usize = 1_000_000;

/// A KLM operator.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Op {
    /// Keystroke or button press (press + release).
    K,
    /// Mouse/wand button press or release (half a click).
    B,
    /// Point to a target.
    P,
    /// Home the hand between devices.
    H,
    /// Mental preparation.
    M,
    /// Wait for the system, seconds.
    R(f64),
}

impl Op {
    /// The operator's letter (`R` for waits).
    pub fn letter(self) -> &'static str {
        match self {
            Op::K => "K",
            Op::B => "B",
            Op::P => "P",
            Op::H => "H",
            Op::M => "M",
            Op::R(_) => "R",
        }
    }
}

/// What a step does in its method, for the M-placement rules.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// Selects or types a command (the default).
    Command,
    /// Part of an argument (`.arg` suffix, or a `"quoted"` string).
    Argument,
    /// Terminates a constant string (`.tc`): Rule 4 removes its M.
    ConstTerminator,
    /// Terminates a variable string (`.tv`): Rule 4 keeps its M.
    VarTerminator,
    /// A redundant terminator (`.rt`): Rule 3 removes its M.
    RedundantTerminator,
}

/// One operator of a method.
#[derive(Debug, Clone, PartialEq)]
pub struct Step {
    /// The operator.
    pub op: Op,
    /// Its role.
    pub role: Role,
    /// The cognitive unit it belongs to, if any.
    pub unit: Option<usize>,
    /// 1-based source line.
    pub line: usize,
}

/// A parsed method.
#[derive(Debug, Clone, PartialEq)]
pub struct Method {
    /// Its `name:` line, or empty.
    pub name: String,
    /// The operators, repetitions expanded.
    pub steps: Vec<Step>,
}

/// A method text that does not parse.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ParseError {
    /// 1-based line.
    pub line: usize,
    /// 1-based column (characters).
    pub col: usize,
    /// What is wrong.
    pub reason: String,
}

impl fmt::Display for ParseError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "method line {}, column {}: {}",
            self.line, self.col, self.reason
        )
    }
}

impl std::error::Error for ParseError {}

/// Which M constant.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum MentalConstant {
    /// Card, Moran and Newell: 1.35 s.
    Cmn,
    /// Kieras: 1.20 s.
    Kieras,
}

/// Which K constant.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Typist {
    /// Average non-secretary typist: 0.28 s.
    Average,
    /// Average skilled typist: 0.20 s.
    Skilled,
}

/// Operator times in seconds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Constants {
    /// K.
    pub k: f64,
    /// B.
    pub b: f64,
    /// P.
    pub p: f64,
    /// H.
    pub h: f64,
    /// M.
    pub m: f64,
}

impl Constants {
    /// The standard constants for a typist and an M convention.
    pub fn standard(typist: Typist, mental: MentalConstant) -> Self {
        Self {
            k: match typist {
                Typist::Average => 0.28,
                Typist::Skilled => 0.20,
            },
            b: 0.10,
            p: 1.10,
            h: 0.40,
            m: match mental {
                MentalConstant::Cmn => 1.35,
                MentalConstant::Kieras => 1.20,
            },
        }
    }

    /// Seconds for one operator.
    pub fn time(&self, op: Op) -> f64 {
        match op {
            Op::K => self.k,
            Op::B => self.b,
            Op::P => self.p,
            Op::H => self.h,
            Op::M => self.m,
            Op::R(t) => t,
        }
    }
}

impl Default for Constants {
    fn default() -> Self {
        Self::standard(Typist::Average, MentalConstant::Cmn)
    }
}

/// Per-operator counts and seconds of a prediction.
#[derive(Debug, Clone, PartialEq)]
pub struct Prediction {
    /// `(letter, count, seconds)` for K, B, P, H, M, R in that order (zeros kept).
    pub by_op: Vec<(&'static str, usize, f64)>,
    /// Total seconds.
    pub total: f64,
}

/// Predicts the execution time of a sequence.
pub fn predict(steps: &[Step], c: &Constants) -> Prediction {
    let mut by_op: Vec<(&'static str, usize, f64)> = ["K", "B", "P", "H", "M", "R"]
        .iter()
        .map(|&l| (l, 0, 0.0))
        .collect();
    for s in steps {
        let i = by_op
            .iter()
            .position(|(l, _, _)| *l == s.op.letter())
            .unwrap_or(0);
        by_op[i].1 += 1;
        by_op[i].2 += c.time(s.op);
    }
    let total = by_op.iter().map(|(_, _, t)| t).sum();
    Prediction { by_op, total }
}

/// Why an M of rule 0 was kept or deleted.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MDecision {
    /// Kept.
    Kept,
    /// Deleted by rule 1, 2, 3 or 4.
    Deleted(u8),
}

/// Places M operators by the heuristic rules 0-4 (see the module docs). M operators
/// already in `steps` are dropped first. Returns the new sequence and, for each M
/// candidate of rule 0, the index of the step it precedes (in `steps` without Ms) and
/// what the rules decided.
pub fn place_mentals(steps: &[Step]) -> (Vec<Step>, Vec<(usize, MDecision)>) {
    let base: Vec<&Step> = steps.iter().filter(|s| s.op != Op::M).collect();
    let mut out = Vec::with_capacity(base.len() * 2);
    let mut decisions = Vec::new();
    let mut units_with_m: Vec<usize> = Vec::new();
    // B operators alternate press and release; a K is a press and its release.
    let mut button_down = false;
    for (i, s) in base.iter().enumerate() {
        let rule0 = match s.op {
            Op::K | Op::B => s.role != Role::Argument,
            Op::P => s.role != Role::Argument,
            _ => false,
        };
        if rule0 {
            let prev = i.checked_sub(1).map(|j| base[j]);
            // Rule 1: a click after its P, a release after its press, and the P of a
            // drag (pointing with the button held, B-down P B-up) after its press.
            let anticipated = matches!(
                (prev.map(|p| p.op), s.op),
                (Some(Op::P), Op::K | Op::B) | (Some(Op::B), Op::B)
            ) || (s.op == Op::P && button_down);
            let decision = if anticipated {
                MDecision::Deleted(1)
            } else if s.unit.is_some_and(|u| units_with_m.contains(&u)) {
                MDecision::Deleted(2)
            } else if s.role == Role::RedundantTerminator {
                MDecision::Deleted(3)
            } else if s.role == Role::ConstTerminator {
                MDecision::Deleted(4)
            } else {
                MDecision::Kept
            };
            if let Some(u) = s.unit {
                // The unit's first M candidate, kept or not, is the unit's one chance.
                units_with_m.push(u);
            }
            if decision == MDecision::Kept {
                out.push(Step {
                    op: Op::M,
                    role: Role::Command,
                    unit: None,
                    line: s.line,
                });
            }
            decisions.push((i, decision));
        }
        match s.op {
            Op::B => button_down = !button_down,
            Op::K => button_down = false,
            _ => {}
        }
        out.push((*s).clone());
    }
    (out, decisions)
}

/// Writes a sequence back as text (`M P B B ...`).
pub fn format_steps(steps: &[Step]) -> String {
    let mut s = String::new();
    for (i, st) in steps.iter().enumerate() {
        if i > 0 {
            s.push(' ');
        }
        match st.op {
            Op::R(t) => s.push_str(&format!("R({t})")),
            op => s.push_str(op.letter()),
        }
    }
    s
}

#[derive(Debug, Clone)]
enum Node {
    Step(Op, Role, usize),
    Str(usize, usize),
    Group(Vec<(Node, usize)>),
    Unit(Vec<(Node, usize)>),
}

struct Parser {
    chars: Vec<char>,
    pos: usize,
    line: usize,
    col: usize,
}

impl Parser {
    fn err(&self, reason: impl Into<String>) -> ParseError {
        ParseError {
            line: self.line,
            col: self.col,
            reason: reason.into(),
        }
    }

    fn peek(&self) -> Option<char> {
        self.chars.get(self.pos).copied()
    }

    fn bump(&mut self) -> Option<char> {
        let c = self.peek()?;
        self.pos += 1;
        if c == '\n' {
            self.line += 1;
            self.col = 1;
        } else {
            self.col += 1;
        }
        Some(c)
    }

    fn skip_ws(&mut self) {
        while let Some(c) = self.peek() {
            if c == '#' {
                while self.peek().is_some_and(|c| c != '\n') {
                    self.bump();
                }
            } else if c.is_whitespace() {
                self.bump();
            } else {
                break;
            }
        }
    }

    /// Parses items until `close` (or end of input when `None`).
    fn items(
        &mut self,
        close: Option<char>,
        depth: usize,
    ) -> Result<Vec<(Node, usize)>, ParseError> {
        if depth > 32 {
            return Err(self.err("groups nested more than 32 deep"));
        }
        let mut items = Vec::new();
        loop {
            self.skip_ws();
            let Some(c) = self.peek() else {
                if let Some(cl) = close {
                    return Err(self.err(format!("missing '{cl}'")));
                }
                return Ok(items);
            };
            if Some(c) == close {
                self.bump();
                return Ok(items);
            }
            let node = match c {
                '(' => {
                    self.bump();
                    Node::Group(self.items(Some(')'), depth + 1)?)
                }
                '{' => {
                    if close == Some('}') {
                        return Err(self.err("cognitive units '{...}' cannot nest"));
                    }
                    self.bump();
                    Node::Unit(self.items(Some('}'), depth + 1)?)
                }
                ')' | '}' => return Err(self.err(format!("unexpected '{c}'"))),
                '"' => {
                    let line = self.line;
                    self.bump();
                    let mut n = 0;
                    loop {
                        match self.bump() {
                            Some('"') => break,
                            Some('\n') | None => return Err(self.err("unterminated string")),
                            Some(_) => n += 1,
                        }
                    }
                    Node::Str(n, line)
                }
                c if c.is_ascii_alphabetic() => self.op()?,
                c => return Err(self.err(format!("unexpected character {c:?}"))),
            };
            let reps = self.repeat()?;
            items.push((node, reps));
        }
    }

    /// Skips spaces and tabs (not line ends or comments).
    fn skip_blanks(&mut self) {
        while self.peek().is_some_and(|c| c == ' ' || c == '\t') {
            self.bump();
        }
    }

    /// An optional `*N` after an item; blanks are allowed around the `*` (`(P K) * 2`,
    /// `(P K) *2`, `(P K)*2`), a line end is not.
    fn repeat(&mut self) -> Result<usize, ParseError> {
        self.skip_blanks();
        if self.peek() != Some('*') {
            return Ok(1);
        }
        self.bump();
        self.skip_blanks();
        let mut digits = String::new();
        while let Some(c) = self.peek().filter(char::is_ascii_digit) {
            digits.push(c);
            self.bump();
        }
        match digits.parse::<usize>() {
            Ok(n) if n <= MAX_STEPS => Ok(n),
            _ => Err(self.err(format!(
                "'*' needs a repeat count from 0 to {MAX_STEPS}, got {digits:?}"
            ))),
        }
    }

    fn op(&mut self) -> Result<Node, ParseError> {
        let (line, col) = (self.line, self.col);
        let at = |reason: String| ParseError { line, col, reason };
        let mut word = String::new();
        while let Some(c) = self
            .peek()
            .filter(|c| c.is_ascii_alphanumeric() || *c == '.')
        {
            word.push(c);
            self.bump();
        }
        let (name, suffix) = match word.split_once('.') {
            Some((n, s)) => (n.to_owned(), Some(s.to_owned())),
            None => (word.clone(), None),
        };
        let op = match name.as_str() {
            "K" => Op::K,
            "B" => Op::B,
            "P" => Op::P,
            "H" => Op::H,
            "M" => Op::M,
            "R" | "W" => {
                if self.peek() != Some('(') {
                    return Err(self.err("R needs a time in seconds: R(0.5)"));
                }
                self.bump();
                let mut num = String::new();
                while let Some(c) = self.peek().filter(|c| *c != ')' && *c != '\n') {
                    num.push(c);
                    self.bump();
                }
                if self.bump() != Some(')') {
                    return Err(self.err("missing ')' after R's time"));
                }
                match num.trim().parse::<f64>() {
                    Ok(t) if t.is_finite() && (0.0..=3600.0).contains(&t) => Op::R(t),
                    _ => return Err(self.err(format!("bad R time {num:?} (0 to 3600 s)"))),
                }
            }
            other => {
                return Err(at(format!(
                    "unknown operator {other:?} (K, B, P, H, M, R(t))"
                )));
            }
        };
        let role = match suffix.as_deref() {
            None => Role::Command,
            Some("arg") => Role::Argument,
            Some("tc") => Role::ConstTerminator,
            Some("tv") => Role::VarTerminator,
            Some("rt") => Role::RedundantTerminator,
            Some(s) => {
                return Err(at(format!(
                    "unknown role suffix .{s} (.arg, .tc, .tv, .rt)"
                )));
            }
        };
        Ok(Node::Step(op, role, line))
    }
}

/// Steps a node list expands to (saturating).
fn size(items: &[(Node, usize)]) -> usize {
    items
        .iter()
        .map(|(node, reps)| node_size(node).saturating_mul(*reps))
        .fold(0, usize::saturating_add)
}

fn node_size(node: &Node) -> usize {
    match node {
        Node::Step(..) => 1,
        Node::Str(n, _) => *n,
        Node::Group(inner) | Node::Unit(inner) => size(inner),
    }
}

fn expand(
    items: &[(Node, usize)],
    unit: Option<usize>,
    next_unit: &mut usize,
    out: &mut Vec<Step>,
) {
    for (node, reps) in items {
        if node_size(node) == 0 {
            // An empty group: nothing to repeat (and no time spent repeating nothing).
            continue;
        }
        for _ in 0..*reps {
            match node {
                Node::Step(op, role, line) => out.push(Step {
                    op: *op,
                    role: *role,
                    unit,
                    line: *line,
                }),
                Node::Str(n, line) => {
                    out.extend((0..*n).map(|_| Step {
                        op: Op::K,
                        role: Role::Argument,
                        unit,
                        line: *line,
                    }));
                }
                Node::Group(inner) => expand(inner, unit, next_unit, out),
                Node::Unit(inner) => {
                    let u = *next_unit;
                    *next_unit += 1;
                    expand(inner, Some(u), next_unit, out);
                }
            }
        }
    }
}

/// Parses a method text.
///
/// Grammar: `#` starts a comment; a line `name: ...` names the method; operators are
/// `K B P H M` and `R(seconds)` (alias `W`), with an optional role suffix `.arg`,
/// `.tc`, `.tv` or `.rt`; `"text"` types one argument K per character; `{ ... }` is a
/// cognitive unit; `( ... )` groups; `*N` after any item repeats it N times (spaces or
/// tabs may stand around the `*`).
pub fn parse_method(text: &str) -> Result<Method, ParseError> {
    let mut name = String::new();
    let mut body = String::with_capacity(text.len());
    for line in text.split('\n') {
        let trimmed = line.trim_start();
        if let Some(rest) = trimmed.strip_prefix("name:") {
            name = rest.trim().to_owned();
            body.push('\n');
        } else {
            body.push_str(line);
            body.push('\n');
        }
    }
    let mut p = Parser {
        chars: body.chars().collect(),
        pos: 0,
        line: 1,
        col: 1,
    };
    let items = p.items(None, 0)?;
    let total = size(&items);
    if total > MAX_STEPS {
        return Err(ParseError {
            line: 1,
            col: 1,
            reason: format!("method expands to more than {MAX_STEPS} steps"),
        });
    }
    let mut steps = Vec::with_capacity(total);
    let mut next_unit = 0;
    expand(&items, None, &mut next_unit, &mut steps);
    Ok(Method { name, steps })
}

/// A method shipped with the tool.
#[derive(Debug, Clone, Copy)]
pub struct Builtin {
    /// Id used as `builtin:<id>`.
    pub id: &'static str,
    /// Method text.
    pub text: &'static str,
}

/// The three methods of the paper's GOMS study (Kwon, Kim and Chai 2006, section 6).
pub const BUILTINS: [Builtin; 3] = [
    Builtin {
        id: "maya-multi-surface",
        text: include_str!("methods/maya-multi-surface.klm"),
    },
    Builtin {
        id: "maya-trimming",
        text: include_str!("methods/maya-trimming.klm"),
    },
    Builtin {
        id: "multires-sculpting",
        text: include_str!("methods/multires-sculpting.klm"),
    },
];

/// The built-in method with this id.
pub fn builtin(id: &str) -> Option<&'static Builtin> {
    BUILTINS.iter().find(|b| b.id == id)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;
    use sculpt_core::{assert_near, tolerance::EXACT_EPS};

    fn seq(text: &str) -> Vec<Step> {
        parse_method(text).unwrap().steps
    }

    fn cmn() -> Constants {
        Constants::standard(Typist::Average, MentalConstant::Cmn)
    }

    #[test]
    fn point_and_double_click() {
        // Rule 0: M P M B M B M B M B; rule 1 deletes the Ms after P and after each B.
        let (placed, _) = place_mentals(&seq("P B B B B"));
        assert_eq!(format_steps(&placed), "M P B B B B");
        // Hand sum: 1.35 + 1.10 + 4 x 0.10.
        assert_near!(
            predict(&placed, &cmn()).total,
            1.35 + 1.10 + 4.0 * 0.10,
            EXACT_EPS
        );
    }

    #[test]
    fn command_name_then_return() {
        // `ls` + Return: rule 2 keeps one M in the unit, rule 4 drops the terminator's.
        let (placed, decisions) = place_mentals(&seq("{K K} K.tc"));
        assert_eq!(format_steps(&placed), "M K K K");
        assert_eq!(
            decisions.iter().map(|d| d.1).collect::<Vec<_>>(),
            vec![
                MDecision::Kept,
                MDecision::Deleted(2),
                MDecision::Deleted(4)
            ]
        );
        assert_near!(predict(&placed, &cmn()).total, 1.35 + 3.0 * 0.28, EXACT_EPS);
    }

    #[test]
    fn menu_pick_then_typed_number() {
        // Home to mouse, pick a menu item (two P/click pairs), home to keys, type a
        // 4-digit argument and Return (terminator of a variable string keeps its M).
        let (placed, _) = place_mentals(&seq("H P B B P B B H \"1234\" K.tv"));
        assert_eq!(format_steps(&placed), "H M P B B M P B B H K K K K M K");
        let hand = 2.0 * 0.40 + 3.0 * 1.35 + 2.0 * 1.10 + 4.0 * 0.10 + 5.0 * 0.28;
        assert_near!(predict(&placed, &cmn()).total, hand, EXACT_EPS);
        let kieras = Constants::standard(Typist::Skilled, MentalConstant::Kieras);
        let hand = 2.0 * 0.40 + 3.0 * 1.20 + 2.0 * 1.10 + 4.0 * 0.10 + 5.0 * 0.20;
        assert_near!(predict(&placed, &kieras).total, hand, EXACT_EPS);
    }

    #[test]
    fn redundant_terminator_and_argument_pointing() {
        // Rule 3 deletes the M before a redundant terminator; P.arg gets no M (rule 0).
        let (placed, _) = place_mentals(&seq("K.tv K.rt P.arg B B"));
        assert_eq!(format_steps(&placed), "M K K P B B");
    }

    #[test]
    fn repetition_waits_and_comments() {
        let m =
            parse_method("name: demo\n# a comment\n(P K)*3 R(0.5) W(1) M # tail\nK*2\n").unwrap();
        assert_eq!(m.name, "demo");
        assert_eq!(format_steps(&m.steps), "P K P K P K R(0.5) R(1) M K K");
        let p = predict(&m.steps, &cmn());
        assert_near!(p.total, 3.0 * 1.10 + 5.0 * 0.28 + 1.5 + 1.35, EXACT_EPS);
    }

    #[test]
    fn parse_errors_point_at_the_problem() {
        let e = parse_method("P K\nP X\n").unwrap_err();
        assert_eq!((e.line, e.col), (2, 3));
        assert!(e.reason.contains("\"X\""), "{e}");
        assert!(
            parse_method("(P K")
                .unwrap_err()
                .reason
                .contains("missing ')'")
        );
        assert!(parse_method("P)").is_err());
        assert!(parse_method("K.foo").unwrap_err().reason.contains(".foo"));
        assert!(parse_method("R(abc)").is_err());
        assert!(parse_method("\"abc").is_err());
        assert!(parse_method("{P {K}}").is_err());
        assert!(
            parse_method("(K*1000000)*1000000")
                .unwrap_err()
                .reason
                .contains("more than")
        );
    }

    /// The built-in methods are task analyses whose Ms are written where the heuristic
    /// rules put them (not fitted to the paper's counts): placing the Ms again changes
    /// nothing.
    #[test]
    fn builtin_methods_write_their_ms_where_the_rules_place_them() {
        for b in BUILTINS {
            let m = parse_method(b.text).unwrap();
            assert!(!m.name.is_empty(), "{}", b.id);
            let (placed, _) = place_mentals(&m.steps);
            assert_eq!(format_steps(&placed), format_steps(&m.steps), "{}", b.id);
        }
        // The sculpting method by hand: M K K M P B P B.
        let m = parse_method(builtin("multires-sculpting").unwrap().text).unwrap();
        assert_eq!(format_steps(&m.steps), "M K K M P B P B");
        let hand = 2.0 * 1.35 + 2.0 * 0.28 + 2.0 * 1.10 + 2.0 * 0.10;
        assert_near!(predict(&m.steps, &cmn()).total, hand, EXACT_EPS);
    }

    /// Regression (issue 19): a drag (press, sweep, release) got a mental operator before
    /// its sweep, against heuristic rule 1.
    #[test]
    fn regression_a_drag_has_no_mental_in_the_middle() {
        let (placed, decisions) = place_mentals(&seq("P B P B"));
        assert_eq!(format_steps(&placed), "M P B P B");
        assert_eq!(
            decisions.iter().map(|d| d.1).collect::<Vec<_>>(),
            [
                MDecision::Kept,
                MDecision::Deleted(1),
                MDecision::Deleted(1),
                MDecision::Deleted(1)
            ]
        );
        // Two drags: each starts a new chunk; a click after a drag is its own command.
        let (placed, _) = place_mentals(&seq("(P B P B)*2 P B B"));
        assert_eq!(format_steps(&placed), "M P B P B M P B P B M P B B");
    }

    /// Regression (issue 19): `(...) *2` with a space was a parse error.
    #[test]
    fn regression_repeat_counts_take_ordinary_spacing() {
        for text in [
            "(P K)*2",
            "(P K) *2",
            "(P K) * 2",
            "(P K)\t*\t2",
            "(P K)* 2",
        ] {
            let m = parse_method(text).unwrap_or_else(|e| panic!("{text:?}: {e}"));
            assert_eq!(format_steps(&m.steps), "P K P K", "{text:?}");
        }
        assert_eq!(format_steps(&seq("K * 3 P")), "K K K P");
        // A repeat count does not continue on the next line.
        assert!(parse_method("(P K)\n*2").is_err());
        assert!(parse_method("(P K) * x").is_err());
    }

    #[derive(Debug, Clone)]
    enum Tree {
        Op(&'static str),
        Group(Vec<(Tree, usize)>),
    }

    fn arb_tree() -> impl Strategy<Value = Tree> {
        let leaf =
            prop_oneof![Just("K"), Just("B"), Just("P"), Just("H"), Just("M")].prop_map(Tree::Op);
        leaf.prop_recursive(3, 24, 4, |inner| {
            proptest::collection::vec((inner, 0usize..4), 1..4).prop_map(Tree::Group)
        })
    }

    /// Writes a tree with the blanks chosen by `gaps` around each `*`.
    fn render(t: &Tree, gaps: &mut impl Iterator<Item = usize>, out: &mut String) {
        match t {
            Tree::Op(l) => out.push_str(l),
            Tree::Group(items) => {
                out.push('(');
                for (i, (item, reps)) in items.iter().enumerate() {
                    if i > 0 {
                        out.push(' ');
                    }
                    render(item, gaps, out);
                    let blank = [" ", "\t", "", "  "];
                    out.push_str(blank[gaps.next().unwrap_or(0) % 4]);
                    out.push('*');
                    out.push_str(blank[gaps.next().unwrap_or(0) % 4]);
                    out.push_str(&reps.to_string());
                }
                out.push(')');
            }
        }
    }

    fn flatten(t: &Tree, out: &mut Vec<&'static str>) {
        match t {
            Tree::Op(l) => out.push(l),
            Tree::Group(items) => {
                for (item, reps) in items {
                    for _ in 0..*reps {
                        flatten(item, out);
                    }
                }
            }
        }
    }

    /// Any well-formed method with any blanks around its `*` parses to its expansion.
    /// Counts the cases: every generated case must be accepted.
    #[test]
    fn spaced_repeats_parse_to_their_expansion() {
        use proptest::test_runner::{Config, TestRunner};
        use std::sync::atomic::{AtomicUsize, Ordering};
        let accepted = AtomicUsize::new(0);
        let cases = 256;
        let mut runner = TestRunner::new(Config::with_cases(cases));
        let strategy = (arb_tree(), proptest::collection::vec(0usize..4, 0..64));
        runner
            .run(&strategy, |(tree, gaps)| {
                let mut text = String::new();
                render(&tree, &mut gaps.into_iter(), &mut text);
                let m = parse_method(&text)
                    .map_err(|e| TestCaseError::fail(format!("{text:?}: {e}")))?;
                let mut want = Vec::new();
                flatten(&tree, &mut want);
                prop_assert_eq!(format_steps(&m.steps), want.join(" "), "{:?}", text);
                accepted.fetch_add(1, Ordering::Relaxed);
                Ok(())
            })
            .unwrap();
        assert_eq!(accepted.load(Ordering::Relaxed), cases as usize);
    }

    proptest! {
        #[test]
        fn parser_never_panics(s in "[KBPHMRW.argtcvr(){}*0-9\" \n#x]{0,60}") {
            if let Ok(m) = parse_method(&s) {
                prop_assert!(m.steps.len() <= MAX_STEPS);
                let p = predict(&m.steps, &cmn());
                prop_assert!(p.total.is_finite());
            }
        }

        #[test]
        fn placing_mentals_is_idempotent(ops in proptest::collection::vec(0usize..6, 0..30)) {
            let text: Vec<&str> = ops.iter().map(|&i| ["K", "B", "P", "H", "K.tc", "P.arg"][i]).collect();
            let steps = seq(&text.join(" "));
            let (once, _) = place_mentals(&steps);
            let (twice, _) = place_mentals(&once);
            prop_assert_eq!(format_steps(&once), format_steps(&twice));
            let non_m = once.iter().filter(|s| s.op != Op::M).count();
            prop_assert_eq!(non_m, steps.len());
        }
    }
}
