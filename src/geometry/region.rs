//! OpenMC-style region expressions over named surfaces.
//!
//! A region is a boolean combination of half-spaces of surfaces, each
//! surface given by an implicit function `f(x)`:
//!
//! | syntax       | meaning                                             |
//! |--------------|-----------------------------------------------------|
//! | `-name`      | negative half-space, `f(x) < 0`                     |
//! | `+name`      | positive half-space, `f(x) > 0`                     |
//! | `A B`        | intersection (juxtaposition, whitespace optional)   |
//! | `A \| B`     | union                                               |
//! | `~A`         | complement of a half-space, complement or group     |
//! | `( A )`      | grouping                                            |
//!
//! Precedence, tightest first: `~`, intersection, `|`. So `-a -b | -c` is
//! `(-a ∩ -b) ∪ -c`, and `~-a -b` is `(~-a) ∩ -b`. Surface names match
//! `[A-Za-z_][A-Za-z0-9_]*`; the sign must be written and must touch the
//! name (`-a`, not `- a` or `a`). `-left -right`, `-a-b` and `-a|-b` are
//! all accepted.
//!
//! [`parse`] compiles an expression into a [`Region`], resolving each name
//! to a surface index; [`Region::contains`] evaluates membership of a point
//! given which side of each surface it lies on.

use std::fmt;
use thiserror::Error;

use super::ray::Aabb;

/// Maximum nesting depth of parentheses and complements accepted by
/// [`parse`], which bounds the recursion of parsing and evaluation.
pub const MAX_DEPTH: usize = 64;

/// Most half-spaces (`-name` / `+name` terms) in one expression accepted by
/// [`parse`]: bounds the work of parsing (linear in the expression) and of
/// every point test of the region.
pub const MAX_TERMS: usize = 4096;

/// Which side of a surface a half-space is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Sense {
    /// `-name`: where the surface function is negative, `f(x) < 0`.
    Negative,
    /// `+name`: where the surface function is positive, `f(x) > 0`.
    Positive,
}

impl Sense {
    /// The opposite sense.
    #[must_use]
    pub fn flipped(self) -> Self {
        match self {
            Self::Negative => Self::Positive,
            Self::Positive => Self::Negative,
        }
    }

    /// Whether a point on the positive side of the surface
    /// (`on_positive_side`) lies in this half-space.
    #[must_use]
    pub fn accepts(self, on_positive_side: bool) -> bool {
        match self {
            Self::Negative => !on_positive_side,
            Self::Positive => on_positive_side,
        }
    }

    /// The sign character used in expressions, `'-'` or `'+'`.
    #[must_use]
    pub fn sign(self) -> char {
        match self {
            Self::Negative => '-',
            Self::Positive => '+',
        }
    }
}

/// Why a region expression was rejected. Positions are 1-based character
/// (not byte) columns in the expression; every message is one line.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum RegionError {
    /// The expression is empty or whitespace only.
    #[error("empty region expression")]
    Empty,
    /// The resolver did not know this surface name.
    #[error("unknown surface `{0}`")]
    UnknownSurface(String),
    /// A `(` without a matching `)`.
    #[error("unbalanced parentheses: `(` at position {position} is never closed")]
    UnclosedParen {
        /// Position of the unmatched `(`.
        position: usize,
    },
    /// A `)` without a matching `(`.
    #[error("unbalanced parentheses: `)` at position {position} has no matching `(`")]
    UnmatchedCloseParen {
        /// Position of the unmatched `)`.
        position: usize,
    },
    /// An operator (`|` or `~`) missing an operand.
    #[error("dangling operator `{op}` at position {position}: missing operand")]
    DanglingOperator {
        /// The operator, `'|'` or `'~'`.
        op: char,
        /// Position of the operator.
        position: usize,
    },
    /// A pair of parentheses with nothing inside.
    #[error("empty parentheses at position {position}")]
    EmptyGroup {
        /// Position of the `(`.
        position: usize,
    },
    /// A `-` or `+` not immediately followed by a surface name.
    #[error("sign `{sign}` at position {position} must be followed directly by a surface name")]
    ExpectedName {
        /// The sign, `'-'` or `'+'`.
        sign: char,
        /// Position of the sign.
        position: usize,
    },
    /// A surface name written without its `-` or `+` sign.
    #[error("surface `{name}` at position {position} needs a sign: write `-{name}` or `+{name}`")]
    MissingSign {
        /// The unsigned name.
        name: String,
        /// Position of the name's first character.
        position: usize,
    },
    /// A character that cannot appear in a region expression.
    #[error("bad character `{ch}` at position {position}")]
    BadCharacter {
        /// The offending character.
        ch: char,
        /// Its position.
        position: usize,
    },
    /// Parentheses and complements nested deeper than [`MAX_DEPTH`].
    #[error("expression nested deeper than {MAX_DEPTH} levels at position {position}")]
    TooDeep {
        /// Position of the `(` or `~` that exceeded the limit.
        position: usize,
    },
    /// More than [`MAX_TERMS`] half-spaces.
    #[error("more than {MAX_TERMS} half-spaces (the term at position {position} is one too many)")]
    TooManyTerms {
        /// Position of the first half-space beyond the limit.
        position: usize,
    },
}

/// Most surfaces (indices `0..64`) a [`Flat`] region may refer to: one bit
/// each in the side set.
pub const FLAT_SURFACES: usize = 64;

/// Most surfaces for which [`Region::flat`] tabulates a general region
/// (a truth table of `2^n` bits, at most 128 bytes).
pub const TABLE_SURFACES: usize = 10;

/// Most values the postfix program of a [`Flat::Program`] keeps on its stack
/// (bits of a `u128`).
const PROGRAM_STACK: usize = 128;

/// One step of a [`Flat::Program`], in postfix order over a stack of bits.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Op {
    /// Push whether the point is in the half-space `sense` of `surface`.
    Half {
        /// Surface index (below [`FLAT_SURFACES`]).
        surface: u8,
        /// The half-space.
        sense: Sense,
    },
    /// Replace the top of the stack by its complement.
    Not,
    /// Pop two values, push their intersection.
    And,
    /// Pop two values, push their union.
    Or,
}

/// A region compiled once into a form evaluated without recursion from the
/// set of sides of a point: bit `i` of `positive` is set when the point is on
/// the positive side of surface `i` (`f_i > 0`). Built by [`Region::flat`];
/// [`Flat::contains`] gives exactly [`Region::contains`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Flat {
    /// An intersection of half-spaces (complements pushed inwards): inside
    /// when `positive & mask == want`. `mask` has the bits of the surfaces
    /// named, `want` those named with `+`. A half-space and its complement
    /// together (`-a +a`) give the empty region, `Never`.
    Intersection {
        /// The surfaces of the intersection.
        mask: u64,
        /// Those whose positive side is wanted.
        want: u64,
    },
    /// The empty region (an intersection of contradictory half-spaces).
    Never,
    /// A truth table over the first `n` surfaces (`n <=`
    /// [`TABLE_SURFACES`]): inside when bit `positive` of the table is set.
    Table {
        /// `2^n` bits, little-endian in 64-bit words.
        bits: Vec<u64>,
        /// Mask of the `n` surfaces (`2^n - 1`).
        mask: u64,
    },
    /// A postfix program over a stack of at most 128 bits (general regions
    /// over more surfaces).
    Program(Vec<Op>),
}

impl Flat {
    /// Heap bytes it owns (with a 16-byte allocator overhead), for memory
    /// estimates.
    #[must_use]
    pub fn heap_bytes(&self) -> usize {
        match self {
            Self::Intersection { .. } | Self::Never => 0,
            Self::Table { bits, .. } => 16 + bits.capacity() * std::mem::size_of::<u64>(),
            Self::Program(ops) => 16 + ops.capacity() * std::mem::size_of::<Op>(),
        }
    }

    /// Whether a point with the sides `positive` (bit `i`: positive side of
    /// surface `i`) is inside the region.
    #[must_use]
    #[inline]
    pub fn contains(&self, positive: u64) -> bool {
        match self {
            Self::Intersection { mask, want } => positive & mask == *want,
            Self::Never => false,
            Self::Table { bits, mask } => {
                let k = (positive & mask) as usize;
                bits[k >> 6] >> (k & 63) & 1 == 1
            }
            Self::Program(ops) => run_program(ops, positive),
        }
    }
}

/// Runs a postfix program (see [`Op`]); the stack is the bits of a `u128`,
/// top at bit 0.
fn run_program(ops: &[Op], positive: u64) -> bool {
    let mut stack = 0_u128;
    for op in ops {
        match *op {
            Op::Half { surface, sense } => {
                let bit = sense.accepts(positive >> surface & 1 == 1);
                stack = stack << 1 | u128::from(bit);
            }
            Op::Not => stack ^= 1,
            Op::And => stack = (stack >> 1) & (stack | !1),
            Op::Or => stack = (stack >> 1) | (stack & 1),
        }
    }
    stack & 1 == 1
}

/// One node of a compiled region. Children of `And` / `Or` are the
/// `children[start..end]` node indices of the owning [`Region`].
#[derive(Debug, Clone, PartialEq, Eq)]
enum Node {
    Half { surface: usize, sense: Sense },
    Not(usize),
    And { start: usize, end: usize },
    Or { start: usize, end: usize },
}

/// A compiled region expression.
///
/// Stored as a flat tree (nodes in a `Vec`, n-ary intersections and unions
/// flattened), so [`Region::contains`] does no allocation and
/// short-circuits. Two regions compare equal when they have the same
/// structure (up to redundant parentheses and whitespace) over the same
/// surfaces with the same display names.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Region {
    nodes: Vec<Node>,
    children: Vec<usize>,
    root: usize,
    /// Display name for each surface index used (first name seen).
    names: Vec<(usize, String)>,
}

/// Parses and compiles a region expression.
///
/// `resolve` maps each surface name to its surface index, returning `None`
/// for unknown names; it is called once per occurrence of a name, left to
/// right.
///
/// # Errors
/// [`RegionError`] for an empty expression, an unknown surface, unbalanced
/// or empty parentheses, a dangling `|` or `~`, a sign without a name, a
/// name without a sign, a bad character, or nesting deeper than
/// [`MAX_DEPTH`]. The first error from the left is reported.
pub fn parse(
    expr: &str,
    resolve: impl FnMut(&str) -> Option<usize>,
) -> Result<Region, RegionError> {
    let tokens = tokenize(expr)?;
    if tokens.is_empty() {
        return Err(RegionError::Empty);
    }
    let mut parser = Parser {
        tokens,
        next: 0,
        resolve,
        names: Vec::new(),
        seen: std::collections::HashSet::new(),
        depth: 0,
    };
    let ast = parser.union(Ctx::Start)?;
    if let Some(token) = parser.peek() {
        // Everything except a stray `)` is consumed by `union`.
        return Err(RegionError::UnmatchedCloseParen {
            position: token.position,
        });
    }
    let mut region = Region {
        nodes: Vec::new(),
        children: Vec::new(),
        root: 0,
        names: parser.names,
    };
    region.root = region.compile(ast);
    Ok(region)
}

impl Region {
    /// Heap bytes this region owns (nodes, children, display names), with a
    /// 16-byte allocator overhead per allocation: for memory estimates.
    #[must_use]
    pub fn heap_bytes(&self) -> usize {
        48 + self.nodes.capacity() * std::mem::size_of::<Node>()
            + self.children.capacity() * std::mem::size_of::<usize>()
            + self.names.capacity() * std::mem::size_of::<(usize, String)>()
            + self
                .names
                .iter()
                .map(|(_, n)| 16 + n.capacity())
                .sum::<usize>()
    }

    /// Whether a point is inside the region, given `side(i)`: `true` when
    /// the point is on the positive side of surface `i` (`f_i(x) > 0`),
    /// `false` when on the negative side.
    ///
    /// Intersections and unions short-circuit left to right, so `side` may
    /// not be called for every surface. Does not allocate.
    #[must_use]
    pub fn contains(&self, mut side: impl FnMut(usize) -> bool) -> bool {
        self.eval(self.root, &mut side)
    }

    fn eval<F: FnMut(usize) -> bool>(&self, id: usize, side: &mut F) -> bool {
        match self.nodes[id] {
            Node::Half { surface, sense } => sense.accepts(side(surface)),
            Node::Not(child) => !self.eval(child, side),
            Node::And { start, end } => self.children[start..end]
                .iter()
                .all(|&c| self.eval(c, side)),
            Node::Or { start, end } => self.children[start..end]
                .iter()
                .any(|&c| self.eval(c, side)),
        }
    }

    /// The distinct surface indices the region refers to, ascending.
    #[must_use]
    pub fn surfaces(&self) -> Vec<usize> {
        let mut out: Vec<usize> = self
            .nodes
            .iter()
            .filter_map(|n| match n {
                Node::Half { surface, .. } => Some(*surface),
                _ => None,
            })
            .collect();
        out.sort_unstable();
        out.dedup();
        out
    }

    /// `Some(i)` when the whole region is the single half-space `-i`
    /// (also when written with complements, e.g. `~+i` or `(~~-i)`).
    #[must_use]
    pub fn single_negative(&self) -> Option<usize> {
        let mut id = self.root;
        let mut negated = false;
        loop {
            match self.nodes[id] {
                Node::Not(child) => {
                    negated = !negated;
                    id = child;
                }
                Node::Half { surface, sense } => {
                    let sense = if negated { sense.flipped() } else { sense };
                    return (sense == Sense::Negative).then_some(surface);
                }
                Node::And { .. } | Node::Or { .. } => return None,
            }
        }
    }

    /// `Some(half-spaces)` when the region is a pure intersection of
    /// half-spaces, in source order (a single half-space counts).
    /// Complements are pushed inwards first (De Morgan), so
    /// `~(+a | +b)` gives `[(a, Negative), (b, Negative)]`; any remaining
    /// union gives `None`.
    fn is_simple_intersection(&self) -> Option<Vec<(usize, Sense)>> {
        let mut out = Vec::new();
        self.collect_intersection(self.root, false, &mut out)
            .then_some(out)
    }

    fn collect_intersection(
        &self,
        id: usize,
        negated: bool,
        out: &mut Vec<(usize, Sense)>,
    ) -> bool {
        match self.nodes[id] {
            Node::Half { surface, sense } => {
                out.push((surface, if negated { sense.flipped() } else { sense }));
                true
            }
            Node::Not(child) => self.collect_intersection(child, !negated, out),
            Node::And { start, end } if !negated => self.children[start..end]
                .iter()
                .all(|&c| self.collect_intersection(c, negated, out)),
            Node::Or { start, end } if negated => self.children[start..end]
                .iter()
                .all(|&c| self.collect_intersection(c, negated, out)),
            Node::And { .. } | Node::Or { .. } => false,
        }
    }

    /// The region compiled into a [`Flat`] form, evaluated without
    /// recursion from a bit set of sides: an intersection of half-spaces
    /// becomes a mask test, a general region over at most
    /// [`TABLE_SURFACES`] surfaces a truth table (when tabulating costs at
    /// most 2^16 node visits), any other a postfix program. `None` when a
    /// surface index is [`FLAT_SURFACES`] or more, or the program would need
    /// more than 128 stack bits (only for nesting far beyond real scenes).
    #[must_use]
    pub fn flat(&self) -> Option<Flat> {
        let surfaces = self.surfaces();
        let n = surfaces.last().map_or(0, |&s| s + 1);
        if n > FLAT_SURFACES {
            return None;
        }
        if let Some(halves) = self.is_simple_intersection() {
            let (mut mask, mut want) = (0_u64, 0_u64);
            for (surface, sense) in halves {
                let bit = 1_u64 << surface;
                let positive = sense == Sense::Positive;
                if mask & bit != 0 && (want & bit != 0) != positive {
                    return Some(Flat::Never);
                }
                mask |= bit;
                if positive {
                    want |= bit;
                }
            }
            return Some(Flat::Intersection { mask, want });
        }
        if n <= TABLE_SURFACES && (self.nodes.len() << n) <= 1 << 16 {
            let mut bits = vec![0_u64; (1_usize << n).div_ceil(64)];
            for k in 0..1_usize << n {
                if self.contains(|i| k >> i & 1 == 1) {
                    bits[k >> 6] |= 1 << (k & 63);
                }
            }
            return Some(Flat::Table {
                bits,
                mask: (1_u64 << n) - 1,
            });
        }
        let mut ops = Vec::new();
        let depth = self.emit(self.root, &mut ops);
        (depth <= PROGRAM_STACK).then_some(Flat::Program(ops))
    }

    /// Appends the postfix program of node `id` to `ops`; returns the stack
    /// depth it needs.
    fn emit(&self, id: usize, ops: &mut Vec<Op>) -> usize {
        match self.nodes[id] {
            Node::Half { surface, sense } => {
                let surface = u8::try_from(surface).expect("flat: surface index below 64");
                ops.push(Op::Half { surface, sense });
                1
            }
            Node::Not(child) => {
                let depth = self.emit(child, ops);
                ops.push(Op::Not);
                depth
            }
            Node::And { start, end } | Node::Or { start, end } => {
                let combine = if matches!(self.nodes[id], Node::And { .. }) {
                    Op::And
                } else {
                    Op::Or
                };
                let mut depth = 0;
                for (k, &child) in self.children[start..end].iter().enumerate() {
                    let d = self.emit(child, ops);
                    if k == 0 {
                        depth = d;
                    } else {
                        depth = depth.max(d + 1);
                        ops.push(combine);
                    }
                }
                depth
            }
        }
    }

    /// A box containing the region, given a box containing each half-space
    /// (`half(surface, sense)`): intersections intersect the boxes, unions
    /// take their hull, and complements are pushed inwards (De Morgan: the
    /// complement of a half-space is the other half-space), so the box is
    /// conservative. An empty intersection may come out as a box with
    /// `min > max` on some axis.
    #[must_use]
    pub fn bounding_box(&self, half: &impl Fn(usize, Sense) -> Aabb) -> Aabb {
        self.node_box(self.root, false, half)
    }

    fn node_box(&self, id: usize, negated: bool, half: &impl Fn(usize, Sense) -> Aabb) -> Aabb {
        match self.nodes[id] {
            Node::Half { surface, sense } => {
                half(surface, if negated { sense.flipped() } else { sense })
            }
            Node::Not(child) => self.node_box(child, !negated, half),
            Node::And { start, end } | Node::Or { start, end } => {
                // An intersection, or a complemented union (De Morgan).
                let meet = matches!(self.nodes[id], Node::And { .. }) != negated;
                let mut boxes = self.children[start..end]
                    .iter()
                    .map(|&c| self.node_box(c, negated, half));
                let first = boxes.next().unwrap_or(Aabb::EVERYTHING);
                boxes.fold(first, |acc, b| {
                    if meet {
                        Aabb {
                            min: acc.min.max(b.min),
                            max: acc.max.min(b.max),
                        }
                    } else {
                        Aabb {
                            min: acc.min.min(b.min),
                            max: acc.max.max(b.max),
                        }
                    }
                })
            }
        }
    }

    /// Appends `ast` (post-order) and returns its node index.
    fn compile(&mut self, ast: Ast) -> usize {
        let node = match ast {
            Ast::Half(surface, sense) => Node::Half { surface, sense },
            Ast::Not(inner) => Node::Not(self.compile(*inner)),
            Ast::And(items) | Ast::Or(items) if items.is_empty() => unreachable_empty_group(),
            Ast::And(items) => {
                let (start, end) = self.compile_children(items);
                Node::And { start, end }
            }
            Ast::Or(items) => {
                let (start, end) = self.compile_children(items);
                Node::Or { start, end }
            }
        };
        self.nodes.push(node);
        self.nodes.len() - 1
    }

    fn compile_children(&mut self, items: Vec<Ast>) -> (usize, usize) {
        let ids: Vec<usize> = items.into_iter().map(|a| self.compile(a)).collect();
        let start = self.children.len();
        self.children.extend(ids);
        (start, self.children.len())
    }

    fn name(&self, surface: usize) -> Option<&str> {
        self.names
            .iter()
            .find(|(s, _)| *s == surface)
            .map(|(_, n)| n.as_str())
    }

    fn fmt_node(&self, id: usize, f: &mut fmt::Formatter<'_>, context: Prec) -> fmt::Result {
        match self.nodes[id] {
            Node::Half { surface, sense } => match self.name(surface) {
                Some(name) => write!(f, "{}{name}", sense.sign()),
                None => write!(f, "{}_{surface}", sense.sign()),
            },
            Node::Not(child) => {
                f.write_str("~")?;
                self.fmt_node(child, f, Prec::Unary)
            }
            Node::And { start, end } => {
                self.fmt_list(&self.children[start..end], " ", Prec::And, context, f)
            }
            Node::Or { start, end } => {
                self.fmt_list(&self.children[start..end], " | ", Prec::Or, context, f)
            }
        }
    }

    fn fmt_list(
        &self,
        items: &[usize],
        separator: &str,
        own: Prec,
        context: Prec,
        f: &mut fmt::Formatter<'_>,
    ) -> fmt::Result {
        let parens = context > own;
        if parens {
            f.write_str("(")?;
        }
        for (i, &c) in items.iter().enumerate() {
            if i > 0 {
                f.write_str(separator)?;
            }
            // Children bind at least as tightly as the next level up.
            let inner = match own {
                Prec::Or => Prec::And,
                Prec::And | Prec::Unary => Prec::Unary,
            };
            self.fmt_node(c, f, inner)?;
        }
        if parens {
            f.write_str(")")?;
        }
        Ok(())
    }
}

/// Only reachable if the parser produced an empty list, which it never
/// does; kept total (no panic) by compiling to an always-false union.
fn unreachable_empty_group() -> Node {
    Node::Or { start: 0, end: 0 }
}

/// Canonical form: single spaces for intersection, ` | ` for union, `~`
/// attached to its operand, and only the parentheses precedence requires.
/// Surfaces are written with the first name that resolved to them.
/// Parsing the output with the same resolver gives an equal [`Region`].
impl fmt::Display for Region {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.fmt_node(self.root, f, Prec::Or)
    }
}

/// Binding strength, loosest first.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Prec {
    Or,
    And,
    Unary,
}

/// Parse tree before flattening into a [`Region`].
enum Ast {
    Half(usize, Sense),
    Not(Box<Ast>),
    And(Vec<Ast>),
    Or(Vec<Ast>),
}

#[derive(Debug)]
enum Tok {
    Half { sense: Sense, name: String },
    Or,
    Not,
    Open,
    Close,
}

#[derive(Debug)]
struct Token {
    tok: Tok,
    /// 1-based character column.
    position: usize,
}

fn is_name_start(c: char) -> bool {
    c.is_ascii_alphabetic() || c == '_'
}

fn is_name_char(c: char) -> bool {
    c.is_ascii_alphanumeric() || c == '_'
}

fn tokenize(expr: &str) -> Result<Vec<Token>, RegionError> {
    let mut tokens = Vec::new();
    let mut terms = 0;
    let mut chars = expr.chars().zip(1..).peekable();
    while let Some((c, position)) = chars.next() {
        let tok = match c {
            c if c.is_whitespace() => continue,
            '|' => Tok::Or,
            '~' => Tok::Not,
            '(' => Tok::Open,
            ')' => Tok::Close,
            '-' | '+' => {
                let sense = if c == '-' {
                    Sense::Negative
                } else {
                    Sense::Positive
                };
                if !chars.peek().is_some_and(|&(n, _)| is_name_start(n)) {
                    return Err(RegionError::ExpectedName { sign: c, position });
                }
                terms += 1;
                if terms > MAX_TERMS {
                    return Err(RegionError::TooManyTerms { position });
                }
                let mut name = String::new();
                while let Some((n, _)) = chars.next_if(|&(n, _)| is_name_char(n)) {
                    name.push(n);
                }
                Tok::Half { sense, name }
            }
            c if is_name_start(c) => {
                let mut name = String::from(c);
                while let Some((n, _)) = chars.next_if(|&(n, _)| is_name_char(n)) {
                    name.push(n);
                }
                return Err(RegionError::MissingSign { name, position });
            }
            ch => return Err(RegionError::BadCharacter { ch, position }),
        };
        tokens.push(Token { tok, position });
    }
    Ok(tokens)
}

/// What precedes the operand being parsed, for error reporting.
#[derive(Debug, Clone, Copy)]
enum Ctx {
    /// Start of the expression.
    Start,
    /// Right after an operator (`|` or `~`) at a position.
    AfterOp(char, usize),
    /// Right after a `(` at a position.
    AfterOpen(usize),
}

struct Parser<F> {
    tokens: Vec<Token>,
    next: usize,
    resolve: F,
    names: Vec<(usize, String)>,
    /// The surfaces in `names` (constant-time membership: linear parsing).
    seen: std::collections::HashSet<usize>,
    depth: usize,
}

impl<F: FnMut(&str) -> Option<usize>> Parser<F> {
    fn peek(&self) -> Option<&Token> {
        self.tokens.get(self.next)
    }

    /// `union := inter ('|' inter)*`
    fn union(&mut self, ctx: Ctx) -> Result<Ast, RegionError> {
        let mut items = Vec::new();
        push_flat(&mut items, self.intersection(ctx)?, false);
        while let Some(Token {
            tok: Tok::Or,
            position,
        }) = self.peek()
        {
            let position = *position;
            self.next += 1;
            let rhs = self.intersection(Ctx::AfterOp('|', position))?;
            push_flat(&mut items, rhs, false);
        }
        Ok(collapse(items, Ast::Or))
    }

    /// `inter := unary unary*`
    fn intersection(&mut self, ctx: Ctx) -> Result<Ast, RegionError> {
        let mut items = Vec::new();
        push_flat(&mut items, self.unary(ctx)?, true);
        while let Some(Token {
            tok: Tok::Half { .. } | Tok::Not | Tok::Open,
            ..
        }) = self.peek()
        {
            let rhs = self.unary(Ctx::Start)?;
            push_flat(&mut items, rhs, true);
        }
        Ok(collapse(items, Ast::And))
    }

    /// `unary := '~' unary | '-'name | '+'name | '(' union ')'`
    fn unary(&mut self, ctx: Ctx) -> Result<Ast, RegionError> {
        let Some(token) = self.tokens.get(self.next) else {
            return Err(match ctx {
                Ctx::Start => RegionError::Empty,
                Ctx::AfterOp(op, position) => RegionError::DanglingOperator { op, position },
                Ctx::AfterOpen(position) => RegionError::UnclosedParen { position },
            });
        };
        let position = token.position;
        match &token.tok {
            Tok::Half { sense, name } => {
                let sense = *sense;
                let surface = (self.resolve)(name)
                    .ok_or_else(|| RegionError::UnknownSurface(name.clone()))?;
                if self.seen.insert(surface) {
                    self.names.push((surface, name.clone()));
                }
                self.next += 1;
                Ok(Ast::Half(surface, sense))
            }
            Tok::Not => {
                self.next += 1;
                self.enter(position)?;
                let inner = self.unary(Ctx::AfterOp('~', position))?;
                self.depth -= 1;
                Ok(Ast::Not(Box::new(inner)))
            }
            Tok::Open => {
                self.next += 1;
                self.enter(position)?;
                let inner = self.union(Ctx::AfterOpen(position))?;
                match self.peek() {
                    Some(Token {
                        tok: Tok::Close, ..
                    }) => self.next += 1,
                    // `union` stops only at `)` or the end.
                    _ => return Err(RegionError::UnclosedParen { position }),
                }
                self.depth -= 1;
                Ok(inner)
            }
            Tok::Or => Err(match ctx {
                Ctx::AfterOp(op, at) => RegionError::DanglingOperator { op, position: at },
                Ctx::Start | Ctx::AfterOpen(_) => {
                    RegionError::DanglingOperator { op: '|', position }
                }
            }),
            Tok::Close => Err(match ctx {
                Ctx::Start => RegionError::UnmatchedCloseParen { position },
                Ctx::AfterOp(op, at) => RegionError::DanglingOperator { op, position: at },
                Ctx::AfterOpen(open) => RegionError::EmptyGroup { position: open },
            }),
        }
    }

    fn enter(&mut self, position: usize) -> Result<(), RegionError> {
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            Err(RegionError::TooDeep { position })
        } else {
            Ok(())
        }
    }
}

/// Pushes `item`, splicing in its operands when it is the same n-ary
/// operator (`and == true`: intersection, else union).
fn push_flat(items: &mut Vec<Ast>, item: Ast, and: bool) {
    match item {
        Ast::And(inner) if and => items.extend(inner),
        Ast::Or(inner) if !and => items.extend(inner),
        other => items.push(other),
    }
}

/// A one-element list is just its element.
fn collapse(mut items: Vec<Ast>, make: fn(Vec<Ast>) -> Ast) -> Ast {
    if items.len() == 1 {
        if let Some(only) = items.pop() {
            return only;
        }
    }
    make(items)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const NAMES: [&str; 5] = ["a", "b", "c", "d", "e"];

    fn resolve(name: &str) -> Option<usize> {
        NAMES.iter().position(|n| *n == name)
    }

    fn p(expr: &str) -> Region {
        parse(expr, resolve).unwrap_or_else(|e| panic!("{expr}: {e}"))
    }

    fn perr(expr: &str) -> RegionError {
        parse(expr, resolve).expect_err(expr)
    }

    /// The postfix-program form of `r`, whatever its number of surfaces.
    fn program_of(r: &Region) -> Flat {
        let mut ops = Vec::new();
        assert!(r.emit(r.root, &mut ops) <= PROGRAM_STACK);
        Flat::Program(ops)
    }

    #[test]
    fn flat_forms_of_typical_cells() {
        // An annular vane: an intersection, a mask test.
        let vane = p("+a -b -c +d");
        assert_eq!(
            vane.flat(),
            Some(Flat::Intersection {
                mask: 0b1111,
                want: 0b1001
            })
        );
        // Complements pushed inwards still give a mask.
        assert_eq!(
            p("~(+a | -b)").flat(),
            Some(Flat::Intersection {
                mask: 0b11,
                want: 0b10
            })
        );
        assert_eq!(p("-a +b +a").flat(), Some(Flat::Never));
        // A union over 3 surfaces: an 8-entry truth table.
        let t = p("-a | -b +c").flat().unwrap();
        let Flat::Table { ref bits, mask } = t else {
            panic!("{t:?}")
        };
        assert_eq!(mask, 0b111);
        // Inside for bit 0 clear (-a: k = 0, 2, 4, 6), or bit 1 clear and
        // bit 2 set (-b +c: k = 4, 5).
        assert_eq!(bits, &vec![0b0111_0101]);
        // 12 surfaces: a postfix program (names s0..s11).
        let names: Vec<String> = (0..12).map(|i| format!("s{i}")).collect();
        let expr = "(-s0 -s1 | +s2) ~(+s3 | -s4) (-s5 | -s6 | -s7) | -s8 +s9 -s10 ~-s11";
        let r = parse(expr, |n| names.iter().position(|m| m == n)).unwrap();
        let flat = r.flat().unwrap();
        assert!(matches!(flat, Flat::Program(_)), "{flat:?}");
        for bits in 0..1_u64 << 12 {
            assert_eq!(
                flat.contains(bits),
                r.contains(|i| bits >> i & 1 == 1),
                "{bits:012b}"
            );
        }
    }

    #[test]
    fn bounding_boxes_follow_de_morgan() {
        // Half-space boxes: -a is x < 1, +a is x > 1, -b is y < 2, +b everything.
        let half = |s: usize, sense: Sense| {
            let mut b = Aabb::EVERYTHING;
            match (s, sense) {
                (0, Sense::Negative) => b.max.x = 1.0,
                (0, Sense::Positive) => b.min.x = 1.0,
                (1, Sense::Negative) => b.max.y = 2.0,
                _ => {}
            }
            b
        };
        let inf = f64::INFINITY;
        let bx = |expr: &str| p(expr).bounding_box(&half);
        assert_eq!(bx("-a -b").max.x, 1.0);
        assert_eq!(bx("-a -b").max.y, 2.0);
        // A union takes the hull: x < 1 or x > 1 is unbounded in x.
        assert_eq!(bx("-a | +a").max.x, inf);
        assert_eq!(bx("-a | +a").min.x, -inf);
        // ~(+a | +b) = -a -b.
        assert_eq!(bx("~(+a | +b)"), bx("-a -b"));
        // ~-a = +a.
        assert_eq!(bx("~-a").min.x, 1.0);
    }

    /// Evaluates a region on the side assignment encoded in `bits`
    /// (bit i set: positive side of surface i).
    fn eval_bits(r: &Region, bits: u32) -> bool {
        r.contains(|i| bits >> i & 1 == 1)
    }

    /// Asserts that `r` agrees with `truth` on all 2^5 side assignments.
    fn assert_truth(expr: &str, truth: impl Fn(&[bool; 5]) -> bool) {
        let r = p(expr);
        for bits in 0..32u32 {
            let pos: [bool; 5] = std::array::from_fn(|i| bits >> i & 1 == 1);
            assert_eq!(eval_bits(&r, bits), truth(&pos), "{expr} at {pos:?}");
        }
    }

    #[test]
    fn single_half_spaces() {
        assert_truth("-a", |s| !s[0]);
        assert_truth("+a", |s| s[0]);
        assert_truth("  +e\t", |s| s[4]);
    }

    #[test]
    fn intersection_and_union() {
        assert_truth("-a -b", |s| !s[0] && !s[1]);
        assert_truth("-a-b", |s| !s[0] && !s[1]);
        assert_truth("-a|-b", |s| !s[0] || !s[1]);
        assert_truth("-a | +b | -c", |s| !s[0] || s[1] || !s[2]);
    }

    #[test]
    fn precedence_intersection_over_union() {
        assert_truth("-a -b | -c", |s| (!s[0] && !s[1]) || !s[2]);
        assert_truth("-c | -a -b", |s| (!s[0] && !s[1]) || !s[2]);
        assert_truth("-a (-b | -c)", |s| !s[0] && (!s[1] || !s[2]));
        assert_truth("-a -b | -c +d | +e", |s| {
            (!s[0] && !s[1]) || (!s[2] && s[3]) || s[4]
        });
        assert_eq!(p("-a -b | -c"), p("(-a -b) | -c"));
        assert_ne!(p("-a -b | -c"), p("-a (-b | -c)"));
    }

    #[test]
    fn complement_binds_tightest() {
        assert_truth("~-a", |s| s[0]);
        assert_truth("~-a -b", |s| s[0] && !s[1]);
        assert_truth("~-a | -b", |s| s[0] || !s[1]);
        assert_truth("~(-a | +b)", |s| s[0] && !s[1]);
        assert_truth("~(-a -b)", |s| s[0] || s[1]);
        assert_truth("~~-a", |s| !s[0]);
        assert_truth("~(-a|-b)~(+c)", |s| s[0] && s[1] && !s[2]);
    }

    #[test]
    fn de_morgan_brute_force() {
        let pairs = [
            ("~(-a | +b)", "+a -b"),
            ("~(-a +b)", "+a | -b"),
            ("~(-a | -b | -c)", "+a +b +c"),
            ("~(-a -b | -c)", "(+a | +b) +c"),
            ("~(~-a | -b)", "-a +b"),
        ];
        for (lhs, rhs) in pairs {
            let (l, r) = (p(lhs), p(rhs));
            for bits in 0..32 {
                assert_eq!(eval_bits(&l, bits), eval_bits(&r, bits), "{lhs} vs {rhs}");
            }
        }
    }

    #[test]
    fn contains_short_circuits() {
        let r = p("-a -b -c");
        let mut calls = Vec::new();
        // a on the positive side: -a fails, nothing else is asked.
        assert!(!r.contains(|i| {
            calls.push(i);
            true
        }));
        assert_eq!(calls, vec![0]);
        let r = p("+a | +b");
        let mut calls = Vec::new();
        assert!(r.contains(|i| {
            calls.push(i);
            true
        }));
        assert_eq!(calls, vec![0]);
    }

    #[test]
    fn surfaces_are_distinct_and_sorted() {
        assert_eq!(p("-e +a | ~(-c -a) +e").surfaces(), vec![0, 2, 4]);
        assert_eq!(p("-b").surfaces(), vec![1]);
    }

    #[test]
    fn single_negative_fast_path() {
        assert_eq!(p("-c").single_negative(), Some(2));
        assert_eq!(p("((-c))").single_negative(), Some(2));
        assert_eq!(p("~+c").single_negative(), Some(2));
        assert_eq!(p("~~-c").single_negative(), Some(2));
        assert_eq!(p("+c").single_negative(), None);
        assert_eq!(p("~-c").single_negative(), None);
        assert_eq!(p("-c -d").single_negative(), None);
        assert_eq!(p("-c | -d").single_negative(), None);
    }

    #[test]
    fn simple_intersection_fast_path() {
        use Sense::{Negative as N, Positive as P};
        assert_eq!(p("-a").is_simple_intersection(), Some(vec![(0, N)]));
        assert_eq!(
            p("-a +b (-c ~-d)").is_simple_intersection(),
            Some(vec![(0, N), (1, P), (2, N), (3, P)])
        );
        assert_eq!(
            p("~(+a | +b)").is_simple_intersection(),
            Some(vec![(0, N), (1, N)])
        );
        assert_eq!(p("-a | -b").is_simple_intersection(), None);
        assert_eq!(p("-a (-b | -c)").is_simple_intersection(), None);
        assert_eq!(p("~(-a -b)").is_simple_intersection(), None);
    }

    #[test]
    fn display_is_canonical() {
        let cases = [
            ("-a", "-a"),
            ("  (( -a ))  ", "-a"),
            ("-a-b", "-a -b"),
            ("-a|-b", "-a | -b"),
            ("(-a -b) -c", "-a -b -c"),
            ("-a | (-b | -c)", "-a | -b | -c"),
            ("-a (-b | -c)", "-a (-b | -c)"),
            ("(-a -b) | -c", "-a -b | -c"),
            ("~ ( -a | +b )", "~(-a | +b)"),
            ("~(-a +b) | ~~-c", "~(-a +b) | ~~-c"),
            ("~(-a) ~(+b)", "~-a ~+b"),
        ];
        for (input, want) in cases {
            let r = p(input);
            assert_eq!(r.to_string(), want, "{input}");
            assert_eq!(p(want), r, "{input}: round trip");
        }
    }

    #[test]
    fn display_uses_resolved_names() {
        let r = parse("-left -right", |n| match n {
            "left" => Some(7),
            "right" => Some(3),
            _ => None,
        })
        .expect("parses");
        assert_eq!(r.to_string(), "-left -right");
        assert_eq!(r.surfaces(), vec![3, 7]);
        assert_eq!(r.single_negative(), None);
    }

    #[test]
    fn error_empty() {
        for expr in ["", "   ", "\t\n"] {
            assert_eq!(perr(expr), RegionError::Empty);
        }
        assert_eq!(RegionError::Empty.to_string(), "empty region expression");
    }

    #[test]
    fn error_unknown_surface() {
        let e = perr("-a | +zeta");
        assert_eq!(e, RegionError::UnknownSurface("zeta".into()));
        assert_eq!(e.to_string(), "unknown surface `zeta`");
    }

    #[test]
    fn error_unbalanced_parentheses() {
        let e = perr("-a (-b | -c");
        assert_eq!(e, RegionError::UnclosedParen { position: 4 });
        assert_eq!(
            e.to_string(),
            "unbalanced parentheses: `(` at position 4 is never closed"
        );
        assert_eq!(perr("((-a)"), RegionError::UnclosedParen { position: 1 });
        let e = perr("-a -b)");
        assert_eq!(e, RegionError::UnmatchedCloseParen { position: 6 });
        assert_eq!(
            e.to_string(),
            "unbalanced parentheses: `)` at position 6 has no matching `(`"
        );
        assert_eq!(
            perr(")-a"),
            RegionError::UnmatchedCloseParen { position: 1 }
        );
        assert_eq!(
            perr("(-a))"),
            RegionError::UnmatchedCloseParen { position: 5 }
        );
    }

    #[test]
    fn error_empty_group() {
        let e = perr("-a ()");
        assert_eq!(e, RegionError::EmptyGroup { position: 4 });
        assert_eq!(e.to_string(), "empty parentheses at position 4");
    }

    #[test]
    fn error_dangling_operator() {
        let e = perr("-a |");
        assert_eq!(
            e,
            RegionError::DanglingOperator {
                op: '|',
                position: 4
            }
        );
        assert_eq!(
            e.to_string(),
            "dangling operator `|` at position 4: missing operand"
        );
        assert_eq!(
            perr("| -a"),
            RegionError::DanglingOperator {
                op: '|',
                position: 1
            }
        );
        assert_eq!(
            perr("-a | | -b"),
            RegionError::DanglingOperator {
                op: '|',
                position: 4
            }
        );
        assert_eq!(
            perr("(| -a)"),
            RegionError::DanglingOperator {
                op: '|',
                position: 2
            }
        );
        assert_eq!(
            perr("(-a |)"),
            RegionError::DanglingOperator {
                op: '|',
                position: 5
            }
        );
        assert_eq!(
            perr("-a ~"),
            RegionError::DanglingOperator {
                op: '~',
                position: 4
            }
        );
        assert_eq!(
            perr("~"),
            RegionError::DanglingOperator {
                op: '~',
                position: 1
            }
        );
        assert_eq!(
            perr("(~)"),
            RegionError::DanglingOperator {
                op: '~',
                position: 2
            }
        );
        assert_eq!(
            perr("~ | -a"),
            RegionError::DanglingOperator {
                op: '~',
                position: 1
            }
        );
    }

    #[test]
    fn error_bad_character() {
        let e = perr("-a & -b");
        assert_eq!(
            e,
            RegionError::BadCharacter {
                ch: '&',
                position: 4
            }
        );
        assert_eq!(e.to_string(), "bad character `&` at position 4");
        assert_eq!(
            perr("-a 1"),
            RegionError::BadCharacter {
                ch: '1',
                position: 4
            }
        );
        // Positions count characters, not bytes.
        assert_eq!(
            perr("~(é"),
            RegionError::BadCharacter {
                ch: 'é',
                position: 3
            }
        );
        assert_eq!(
            perr("-aé"),
            RegionError::BadCharacter {
                ch: 'é',
                position: 3
            }
        );
    }

    #[test]
    fn error_sign_without_name() {
        let e = perr("-a - b");
        assert_eq!(
            e,
            RegionError::ExpectedName {
                sign: '-',
                position: 4
            }
        );
        assert_eq!(
            e.to_string(),
            "sign `-` at position 4 must be followed directly by a surface name"
        );
        assert_eq!(
            perr("+"),
            RegionError::ExpectedName {
                sign: '+',
                position: 1
            }
        );
        assert_eq!(
            perr("-1"),
            RegionError::ExpectedName {
                sign: '-',
                position: 1
            }
        );
        assert_eq!(
            perr("-(a)"),
            RegionError::ExpectedName {
                sign: '-',
                position: 1
            }
        );
    }

    #[test]
    fn error_name_without_sign() {
        let e = perr("-a b_1");
        assert_eq!(
            e,
            RegionError::MissingSign {
                name: "b_1".into(),
                position: 4
            }
        );
        assert_eq!(
            e.to_string(),
            "surface `b_1` at position 4 needs a sign: write `-b_1` or `+b_1`"
        );
    }

    #[test]
    fn error_too_deep() {
        let ok = format!("{}-a{}", "(".repeat(MAX_DEPTH), ")".repeat(MAX_DEPTH));
        assert_eq!(p(&ok).single_negative(), Some(0));
        let deep = format!(
            "{}-a{}",
            "(".repeat(MAX_DEPTH + 1),
            ")".repeat(MAX_DEPTH + 1)
        );
        let e = perr(&deep);
        assert_eq!(
            e,
            RegionError::TooDeep {
                position: MAX_DEPTH + 1
            }
        );
        assert_eq!(
            e.to_string(),
            format!(
                "expression nested deeper than {MAX_DEPTH} levels at position {}",
                MAX_DEPTH + 1
            )
        );
        let nots = format!("{}-a", "~".repeat(100_000));
        assert!(matches!(perr(&nots), RegionError::TooDeep { .. }));
    }

    #[test]
    fn error_too_many_terms() {
        let ok = vec!["-a"; MAX_TERMS].join(" ");
        assert_eq!(p(&ok).surfaces(), vec![0]);
        let long = vec!["-a"; 100_000].join(" ");
        // The first term beyond the limit starts at column 3 MAX_TERMS + 1.
        assert_eq!(
            perr(&long),
            RegionError::TooManyTerms {
                position: 3 * MAX_TERMS + 1
            }
        );
    }

    #[test]
    fn names_with_digits_and_underscores() {
        let r = parse("-_x1 +Cyl_2", |n| match n {
            "_x1" => Some(0),
            "Cyl_2" => Some(1),
            _ => None,
        })
        .expect("parses");
        assert_eq!(r.to_string(), "-_x1 +Cyl_2");
    }

    // ---- property test against an independent reference -----------------

    /// Reference expression tree (independent of the parser's AST).
    #[derive(Debug, Clone)]
    enum E {
        Half(usize, bool), // (surface, positive?)
        Not(Box<E>),
        And(Vec<E>),
        Or(Vec<E>),
    }

    /// Reference semantics, straight recursion.
    fn reference(e: &E, bits: u32) -> bool {
        match e {
            E::Half(i, positive) => (bits >> i & 1 == 1) == *positive,
            E::Not(x) => !reference(x, bits),
            E::And(xs) => xs.iter().all(|x| reference(x, bits)),
            E::Or(xs) => xs.iter().any(|x| reference(x, bits)),
        }
    }

    /// Renders with every compound operand parenthesised; `tight` drops all
    /// optional whitespace.
    fn render_full(e: &E, tight: bool) -> String {
        let sp = if tight { "" } else { " " };
        match e {
            E::Half(i, positive) => format!("{}{}", if *positive { '+' } else { '-' }, NAMES[*i]),
            E::Not(x) => format!("~({})", render_full(x, tight)),
            E::And(xs) => xs
                .iter()
                .map(|x| format!("({})", render_full(x, tight)))
                .collect::<Vec<_>>()
                .join(sp),
            E::Or(xs) => xs
                .iter()
                .map(|x| format!("({})", render_full(x, tight)))
                .collect::<Vec<_>>()
                .join(&format!("{sp}|{sp}")),
        }
    }

    /// Renders with the fewest parentheses the precedence rules allow
    /// (prec: 0 union, 1 intersection, 2 unary).
    fn render_min(e: &E, context: u8) -> String {
        let (own, s) = match e {
            E::Half(..) => (2, render_full(e, false)),
            E::Not(x) => (2, format!("~{}", render_min(x, 2))),
            E::And(xs) => (
                1,
                xs.iter()
                    .map(|x| render_min(x, 2))
                    .collect::<Vec<_>>()
                    .join(" "),
            ),
            E::Or(xs) => (
                0,
                xs.iter()
                    .map(|x| render_min(x, 1))
                    .collect::<Vec<_>>()
                    .join(" | "),
            ),
        };
        if context > own { format!("({s})") } else { s }
    }

    fn arb_expr() -> impl Strategy<Value = E> {
        let leaf = (0..NAMES.len(), any::<bool>()).prop_map(|(i, s)| E::Half(i, s));
        leaf.prop_recursive(5, 40, 4, |inner| {
            prop_oneof![
                inner.clone().prop_map(|x| E::Not(Box::new(x))),
                prop::collection::vec(inner.clone(), 1..4).prop_map(E::And),
                prop::collection::vec(inner, 1..4).prop_map(E::Or),
            ]
        })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(512))]

        #[test]
        fn matches_reference_evaluator(e in arb_expr()) {
            let renders = [render_full(&e, false), render_full(&e, true), render_min(&e, 0)];
            let regions: Vec<Region> = renders
                .iter()
                .map(|s| parse(s, resolve).map_err(|err| TestCaseError::fail(format!("{s}: {err}"))))
                .collect::<Result<_, _>>()?;
            for (s, r) in renders.iter().zip(&regions) {
                // Display round trip gives the same region.
                let canonical = r.to_string();
                let again = parse(&canonical, resolve)
                    .map_err(|err| TestCaseError::fail(format!("{canonical}: {err}")))?;
                prop_assert_eq!(&again, r, "{} -> {}", s, canonical);
                prop_assert_eq!(again.to_string(), canonical.clone());
                for bits in 0..32u32 {
                    let want = reference(&e, bits);
                    prop_assert_eq!(eval_bits(r, bits), want, "{} bits {:05b}", s, bits);
                    prop_assert_eq!(eval_bits(&again, bits), want, "{} bits {:05b}", canonical, bits);
                }
                // Fast paths agree with the full evaluation.
                if let Some(halves) = r.is_simple_intersection() {
                    for bits in 0..32u32 {
                        let all = halves.iter().all(|&(i, sense)| sense.accepts(bits >> i & 1 == 1));
                        prop_assert_eq!(all, eval_bits(r, bits));
                    }
                }
                if let Some(i) = r.single_negative() {
                    for bits in 0..32u32 {
                        prop_assert_eq!(bits >> i & 1 == 0, eval_bits(r, bits));
                    }
                }
                // The flat form (mask or table) and the postfix program
                // agree with the recursive evaluation on every side set.
                let flat = r.flat().expect("5 surfaces always flatten");
                let program = program_of(r);
                for bits in 0..32u32 {
                    let want = eval_bits(r, bits);
                    prop_assert_eq!(flat.contains(u64::from(bits)), want, "{} flat {:05b}", s, bits);
                    prop_assert_eq!(program.contains(u64::from(bits)), want, "{} program {:05b}", s, bits);
                }
            }
            // All renderings of one tree compile to the same region.
            prop_assert_eq!(&regions[0], &regions[1]);
            prop_assert_eq!(&regions[1], &regions[2]);
        }

        #[test]
        fn never_panics_on_arbitrary_input(s in "[-+|~() a-c1&]{0,24}") {
            let _ = parse(&s, resolve);
        }
    }
}
