//! Whether a JPEG file's compressed data is whole: every Huffman code valid, exactly the blocks
//! the frame needs in every scan (no data missing before a marker, none left over after the
//! last block), restart markers where the restart interval puts them, and, between them, the
//! scans code every coefficient of every component to full precision.
//!
//! The decoders ember can use (zune-jpeg, through the `image` crate, even in its strict mode;
//! jpeg-decoder likewise) fill data that ends early with zeros and ignore data left over, as
//! browsers do: a file cut short with an end-of-image marker appended, or with a stretch of it
//! zeroed, decodes without an error into a partly grey or garbled texture. This walks the
//! entropy-coded data as a decoder does (ITU T.81 F.2.2 and G.1.2: sequential and progressive
//! Huffman coding) without computing any pixel, and says where it stops making sense.
//! Arithmetic coding and lossless JPEG are left to the decoder (which refuses them).

/// Why the data is not whole, in words.
pub type Problem = String;

/// A Huffman table in the canonical form decoding walks (T.81 F.2.2.3).
#[derive(Clone, Default)]
struct Huffman {
    /// Per code length 1..=16: the largest code (−1: none), the smallest, and where its values
    /// start in `values`.
    max_code: [i32; 17],
    min_code: [i32; 17],
    first: [usize; 17],
    values: Vec<u8>,
}

impl Huffman {
    /// The table of a DHT segment's code counts per length (16) and values.
    fn new(counts: &[u8], values: &[u8]) -> Result<Huffman, Problem> {
        let mut t = Huffman { values: values.to_vec(), ..Huffman::default() };
        let (mut code, mut k) = (0i32, 0usize);
        for len in 1..=16 {
            let n = counts[len - 1] as i32;
            t.first[len] = k;
            t.min_code[len] = code;
            code += n;
            k += n as usize;
            t.max_code[len] = if n > 0 { code - 1 } else { -1 };
            if code > 1 << len {
                return Err("a Huffman table with more codes than its lengths allow".into());
            }
            code <<= 1;
        }
        Ok(t)
    }
}

/// Reads the bits of entropy-coded data: `FF 00` is a data byte `FF`; any other `FF xx` is a
/// marker, where the data ends.
struct Bits<'a> {
    data: &'a [u8],
    at: usize,
    byte: u8,
    left: u8,
}

impl Bits<'_> {
    fn bit(&mut self) -> Result<u32, Problem> {
        if self.left == 0 {
            let b = *self.data.get(self.at).ok_or("the file ends inside the compressed data")?;
            if b == 0xFF {
                match self.data.get(self.at + 1) {
                    Some(0) => self.at += 1,
                    _ => return Err("the compressed data ends early (a marker where data was expected)".into()),
                }
            }
            self.at += 1;
            self.byte = b;
            self.left = 8;
        }
        self.left -= 1;
        Ok(((self.byte >> self.left) & 1) as u32)
    }

    fn bits(&mut self, n: u8) -> Result<u32, Problem> {
        (0..n).try_fold(0, |v, _| Ok((v << 1) | self.bit()?))
    }

    fn decode(&mut self, t: &Huffman) -> Result<u8, Problem> {
        let mut code = self.bit()? as i32;
        for len in 1..=16 {
            if code <= t.max_code[len] {
                let i = t.first[len] + (code - t.min_code[len]) as usize;
                return t.values.get(i).copied().ok_or_else(|| "a Huffman code without a value".into());
            }
            code = (code << 1) | self.bit()? as i32;
        }
        Err("an invalid Huffman code in the compressed data".into())
    }

    /// Goes to the next byte boundary, then past `FF` fill bytes: where a marker must be.
    fn align(&mut self) {
        self.left = 0;
        while self.data.get(self.at) == Some(&0xFF) && self.data.get(self.at + 1) == Some(&0xFF) {
            self.at += 1;
        }
    }

    /// The marker at the current (aligned) position, if there is one.
    fn marker(&self) -> Option<u8> {
        match (self.data.get(self.at), self.data.get(self.at + 1)) {
            (Some(0xFF), Some(&m)) if m != 0 => Some(m),
            _ => None,
        }
    }
}

struct Component {
    id: u8,
    h: u32,
    v: u32,
    /// Blocks across and down (of the component's own size).
    blocks_x: u32,
    blocks_y: u32,
    /// Per zig-zag coefficient, the lowest bit coded so far (`None`: not yet).
    coded_to: [Option<u8>; 64],
    /// Progressive: per block, which coefficients are non-zero so far (for refinement scans).
    nonzero: Vec<u64>,
}

struct Frame {
    progressive: bool,
    precision: u8,
    components: Vec<Component>,
    /// MCUs across and down of an interleaved scan.
    mcus_x: u32,
    mcus_y: u32,
}

/// Checks the JPEG file `bytes` (see the module documentation); `Ok` also for the kinds this
/// does not walk (arithmetic coding, lossless, a height given later by a DNL marker), which the
/// decoder judges.
pub fn check(bytes: &[u8]) -> Result<(), Problem> {
    if !bytes.starts_with(&[0xFF, 0xD8]) {
        return Err("no start-of-image marker".into());
    }
    let mut at = 2;
    let mut dc: [Option<Huffman>; 4] = Default::default();
    let mut ac: [Option<Huffman>; 4] = Default::default();
    let mut restart = 0u32;
    let mut frame: Option<Frame> = None;
    loop {
        // Fill bytes, then a marker.
        while bytes.get(at) == Some(&0xFF) && bytes.get(at + 1) == Some(&0xFF) {
            at += 1;
        }
        let marker = match (bytes.get(at), bytes.get(at + 1)) {
            (Some(0xFF), Some(&m)) => m,
            (None, _) => return Err("no end-of-image marker".into()),
            _ => return Err(format!("data where a marker was expected (at byte {at})")),
        };
        at += 2;
        if marker == 0xD9 {
            break;
        }
        if (0xD0..=0xD7).contains(&marker) || marker == 0x01 {
            continue; // no segment: a stray restart marker (after a scan's last block) or TEM
        }
        let len = match (bytes.get(at), bytes.get(at + 1)) {
            (Some(&a), Some(&b)) => u16::from_be_bytes([a, b]) as usize,
            _ => return Err("the file ends inside a marker segment".into()),
        };
        let seg = bytes.get(at + 2..at + len.max(2)).ok_or("the file ends inside a marker segment")?;
        if len < 2 {
            return Err("a marker segment shorter than its length field".into());
        }
        at += len;
        match marker {
            0xC0..=0xC2 => frame = Some(parse_frame(seg, marker == 0xC2)?),
            // Arithmetic coding, lossless, hierarchical: the decoder's to judge.
            0xC3 | 0xC5..=0xC7 | 0xC9..=0xCB | 0xCD..=0xCF => return Ok(()),
            0xC4 => parse_huffman(seg, &mut dc, &mut ac)?,
            0xDD => {
                let interval = seg.get(..2).ok_or("a short DRI segment")?;
                restart = u16::from_be_bytes([interval[0], interval[1]]) as u32;
            }
            0xDA => {
                let f = frame.as_mut().ok_or("a scan before the frame header")?;
                if f.mcus_y == 0 {
                    return Ok(()); // the height comes in a DNL marker: left to the decoder
                }
                let mut bits = Bits { data: bytes, at, byte: 0, left: 0 };
                scan(f, seg, &dc, &ac, restart, &mut bits)?;
                bits.align();
                if bits.marker().is_none() {
                    return Err(if bits.at >= bytes.len() {
                        "the file ends after the compressed data, without an end-of-image marker".into()
                    } else {
                        "data left over after the last block of a scan (corrupt compressed data)".into()
                    });
                }
                at = bits.at;
            }
            _ => {} // APPn, COM, DQT, ...: nothing to check here
        }
    }
    let f = frame.ok_or("no frame header")?;
    for c in &f.components {
        if let Some(k) = c.coded_to.iter().position(|b| *b != Some(0)) {
            return Err(format!(
                "component {} has coefficient {k} {}: scans are missing (a file cut short?)",
                c.id,
                if c.coded_to[k].is_none() { "never coded" } else { "not coded to full precision" }
            ));
        }
    }
    Ok(())
}

fn parse_frame(seg: &[u8], progressive: bool) -> Result<Frame, Problem> {
    let bad = || Problem::from("a malformed frame header");
    let precision = *seg.first().ok_or_else(bad)?;
    let height = u16::from_be_bytes([*seg.get(1).ok_or_else(bad)?, *seg.get(2).ok_or_else(bad)?]) as u32;
    let width = u16::from_be_bytes([*seg.get(3).ok_or_else(bad)?, *seg.get(4).ok_or_else(bad)?]) as u32;
    let n = *seg.get(5).ok_or_else(bad)? as usize;
    if n == 0 || width == 0 || seg.len() < 6 + 3 * n || !(precision == 8 || precision == 12) {
        return Err(bad());
    }
    let mut components = Vec::with_capacity(n);
    for c in seg[6..6 + 3 * n].chunks_exact(3) {
        let (h, v) = ((c[1] >> 4) as u32, (c[1] & 15) as u32);
        if !(1..=4).contains(&h) || !(1..=4).contains(&v) {
            return Err(bad());
        }
        components.push(Component {
            id: c[0],
            h,
            v,
            blocks_x: 0,
            blocks_y: 0,
            coded_to: [None; 64],
            nonzero: Vec::new(),
        });
    }
    let hmax = components.iter().map(|c| c.h).max().unwrap_or(1);
    let vmax = components.iter().map(|c| c.v).max().unwrap_or(1);
    for c in &mut components {
        c.blocks_x = (width * c.h).div_ceil(hmax).div_ceil(8);
        c.blocks_y = (height * c.v).div_ceil(vmax).div_ceil(8);
    }
    Ok(Frame {
        progressive,
        precision,
        components,
        mcus_x: width.div_ceil(8 * hmax),
        mcus_y: height.div_ceil(8 * vmax),
    })
}

fn parse_huffman(seg: &[u8], dc: &mut [Option<Huffman>; 4], ac: &mut [Option<Huffman>; 4]) -> Result<(), Problem> {
    let bad = || Problem::from("a malformed Huffman table segment");
    let mut rest = seg;
    while !rest.is_empty() {
        let class_id = rest[0];
        let counts = rest.get(1..17).ok_or_else(bad)?;
        let n: usize = counts.iter().map(|&c| c as usize).sum();
        let values = rest.get(17..17 + n).ok_or_else(bad)?;
        let table = Huffman::new(counts, values)?;
        let (class, id) = (class_id >> 4, (class_id & 15) as usize);
        match (class, dc.get_mut(id), ac.get_mut(id)) {
            (0, Some(slot), _) | (1, _, Some(slot)) => *slot = Some(table),
            _ => return Err(bad()),
        }
        rest = &rest[17 + n..];
    }
    Ok(())
}

/// Walks one scan's compressed data (its header `seg`), updating what `f`'s components have
/// had coded.
fn scan(
    f: &mut Frame,
    seg: &[u8],
    dc: &[Option<Huffman>; 4],
    ac: &[Option<Huffman>; 4],
    restart: u32,
    bits: &mut Bits,
) -> Result<(), Problem> {
    let bad = || Problem::from("a malformed scan header");
    let n = *seg.first().ok_or_else(bad)? as usize;
    let tail = seg.get(1 + 2 * n..4 + 2 * n).ok_or_else(bad)?;
    let (ss, se, ah, al) = (tail[0] as usize, tail[1] as usize, tail[2] >> 4, tail[2] & 15);
    // Each component of the scan: its index in the frame and its tables.
    let mut members = Vec::with_capacity(n);
    for c in seg[1..1 + 2 * n].chunks_exact(2) {
        let i = f.components.iter().position(|x| x.id == c[0]).ok_or("a scan of a component the frame lacks")?;
        if members.iter().any(|&(j, _, _)| j == i) {
            return Err(bad());
        }
        members.push((i, (c[1] >> 4) as usize, (c[1] & 15) as usize));
    }
    if n == 0 || n > 4 || se > 63 || ss > se || (n > 1 && ss > 0) || al > 13 || (ah != 0 && ah != al + 1) {
        return Err(bad());
    }
    if !f.progressive && (ss != 0 || se != 63 || ah != 0 || al != 0) {
        return Err(bad());
    }
    if f.progressive && ss == 0 && se != 0 {
        return Err(bad());
    }
    // What this scan codes: coefficients ss..=se of its components, from bit `al` (after those
    // above it were coded, for a refinement).
    for &(i, _, _) in &members {
        let c = &mut f.components[i];
        for k in ss..=se {
            let expected = if ah == 0 { None } else { Some(ah) };
            if c.coded_to[k] != expected {
                return Err(format!("scans out of order: coefficient {k} of component {} coded twice", c.id));
            }
            c.coded_to[k] = Some(al);
        }
        if f.progressive && ss > 0 && c.nonzero.is_empty() {
            c.nonzero = vec![0; c.blocks_x as usize * c.blocks_y as usize];
        }
    }
    let table = |tables: &[Option<Huffman>; 4], id: usize, what: &str| -> Result<Huffman, Problem> {
        tables.get(id).cloned().flatten().ok_or_else(|| format!("a scan uses {what} Huffman table {id}, never defined"))
    };
    let max_dc = f.precision + 3; // the largest DC difference category (T.81 F.1.2.1)
    let max_ac = f.precision + 2;
    let tables: Vec<(Option<Huffman>, Option<Huffman>)> = members
        .iter()
        .map(|&(_, td, ta)| {
            let d = (ss == 0 && ah == 0).then(|| table(dc, td, "DC")).transpose()?;
            let a = (se > 0).then(|| table(ac, ta, "AC")).transpose()?;
            Ok((d, a))
        })
        .collect::<Result<_, Problem>>()?;
    // The blocks in coding order: an interleaved scan's MCUs hold h × v blocks of each
    // component; a one-component scan goes block by block.
    let (units_x, units_y) = if n == 1 {
        let c = &f.components[members[0].0];
        (c.blocks_x, c.blocks_y)
    } else {
        (f.mcus_x, f.mcus_y)
    };
    let units = units_x as u64 * units_y as u64;
    let mut eobrun = 0u32;
    let mut next_restart = 0u8;
    for unit in 0..units {
        if restart > 0 && unit > 0 && unit % restart as u64 == 0 {
            bits.align();
            match bits.marker() {
                Some(m) if m == 0xD0 + next_restart => {}
                _ => return Err("a restart marker missing or out of order (corrupt compressed data)".into()),
            }
            bits.at += 2;
            next_restart = (next_restart + 1) % 8;
            eobrun = 0;
        }
        let (ux, uy) = ((unit % units_x as u64) as u32, (unit / units_x as u64) as u32);
        for (m, &(i, _, _)) in members.iter().enumerate() {
            let c = &mut f.components[i];
            let (bw, bh) = if n == 1 { (1, 1) } else { (c.h, c.v) };
            for by in 0..bh {
                for bx in 0..bw {
                    let (x, y) = (ux * bw + bx, uy * bh + by);
                    let (dct, act) = &tables[m];
                    let block = (y < c.blocks_y && x < c.blocks_x).then(|| (y * c.blocks_x + x) as usize);
                    let nonzero = block.and_then(|b| c.nonzero.get_mut(b));
                    if !f.progressive {
                        sequential_block(bits, dct.as_ref(), act.as_ref(), max_dc, max_ac)?;
                    } else if ss == 0 {
                        match dct {
                            Some(t) => {
                                let cat = bits.decode(t)?;
                                if cat > max_dc {
                                    return Err("a DC difference out of range (corrupt compressed data)".into());
                                }
                                bits.bits(cat)?;
                            }
                            None => {
                                bits.bit()?;
                            }
                        }
                    } else {
                        let act = act.as_ref().ok_or("an AC scan without a table")?;
                        let mut scratch = 0u64;
                        let nonzero = nonzero.unwrap_or(&mut scratch);
                        if ah == 0 {
                            ac_first(bits, act, ss, se, max_ac, &mut eobrun, nonzero)?;
                        } else {
                            ac_refine(bits, act, ss, se, &mut eobrun, nonzero)?;
                        }
                    }
                }
            }
        }
    }
    Ok(())
}

/// One block of a sequential scan: its DC difference and 63 AC coefficients.
fn sequential_block(
    bits: &mut Bits,
    dc: Option<&Huffman>,
    ac: Option<&Huffman>,
    max_dc: u8,
    max_ac: u8,
) -> Result<(), Problem> {
    let (dc, ac) = (dc.ok_or("a scan without a DC table")?, ac.ok_or("a scan without an AC table")?);
    let cat = bits.decode(dc)?;
    if cat > max_dc {
        return Err("a DC difference out of range (corrupt compressed data)".into());
    }
    bits.bits(cat)?;
    let mut k = 1;
    while k < 64 {
        let rs = bits.decode(ac)?;
        let (r, s) = ((rs >> 4) as usize, rs & 15);
        if s == 0 {
            if r != 15 {
                break; // end of block
            }
            k += 16;
        } else {
            k += r;
            if k > 63 || s > max_ac {
                return Err("a coefficient out of range (corrupt compressed data)".into());
            }
            bits.bits(s)?;
            k += 1;
        }
    }
    if k > 64 {
        return Err("a run of zeros past the end of a block (corrupt compressed data)".into());
    }
    Ok(())
}

/// One block of a progressive first AC scan (T.81 G.1.2.2): coefficients `ss..=se`, or part of
/// an end-of-band run.
fn ac_first(
    bits: &mut Bits,
    ac: &Huffman,
    ss: usize,
    se: usize,
    max_ac: u8,
    eobrun: &mut u32,
    nonzero: &mut u64,
) -> Result<(), Problem> {
    if *eobrun > 0 {
        *eobrun -= 1;
        return Ok(());
    }
    let mut k = ss;
    while k <= se {
        let rs = bits.decode(ac)?;
        let (r, s) = ((rs >> 4) as usize, rs & 15);
        if s == 0 {
            if r < 15 {
                *eobrun = (1u32 << r) - 1 + bits.bits(r as u8)?;
                return Ok(());
            }
            k += 16;
        } else {
            k += r;
            if k > se || s > max_ac {
                return Err("a coefficient out of range (corrupt compressed data)".into());
            }
            bits.bits(s)?;
            *nonzero |= 1 << k;
            k += 1;
        }
    }
    if k > se + 1 {
        return Err("a run of zeros past the end of a band (corrupt compressed data)".into());
    }
    Ok(())
}

/// One block of a progressive refinement AC scan (T.81 G.1.2.3, as libjpeg's
/// `decode_mcu_AC_refine`): a correction bit for each coefficient already non-zero, and new
/// coefficients of magnitude one.
fn ac_refine(
    bits: &mut Bits,
    ac: &Huffman,
    ss: usize,
    se: usize,
    eobrun: &mut u32,
    nonzero: &mut u64,
) -> Result<(), Problem> {
    let mut k = ss;
    if *eobrun == 0 {
        while k <= se {
            let rs = bits.decode(ac)?;
            let (mut r, s) = ((rs >> 4) as i32, rs & 15);
            if s != 0 {
                if s != 1 {
                    return Err("a refinement coefficient out of range (corrupt compressed data)".into());
                }
                bits.bit()?;
            } else if r != 15 {
                *eobrun = (1u32 << r) + bits.bits(r as u8)?;
                break;
            }
            // Past the non-zero coefficients (a correction bit each) and r zero ones.
            while k <= se {
                if *nonzero & (1 << k) != 0 {
                    bits.bit()?;
                } else {
                    r -= 1;
                    if r < 0 {
                        break;
                    }
                }
                k += 1;
            }
            if s != 0 {
                if k > se {
                    return Err("a refinement coefficient past the end of a band (corrupt compressed data)".into());
                }
                *nonzero |= 1 << k;
            }
            k += 1;
        }
    }
    if *eobrun > 0 {
        for k in k..=se {
            if *nonzero & (1 << k) != 0 {
                bits.bit()?;
            }
        }
        *eobrun -= 1;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::check;

    fn earth() -> Vec<u8> {
        std::fs::read(concat!(env!("CARGO_MANIFEST_DIR"), "/scenes/earthmap.jpg")).unwrap()
    }

    #[test]
    fn whole_files_pass_and_damaged_ones_do_not() {
        let good = earth();
        assert_eq!(check(&good), Ok(()));
        let n = good.len();
        // Cut in half, an end-of-image marker appended.
        let mut half = good[..n / 2].to_vec();
        half.extend([0xFF, 0xD9]);
        assert!(check(&half).unwrap_err().contains("ends early"), "{:?}", check(&half));
        // A third zeroed in the middle.
        let mut zeroed = good.clone();
        zeroed[n / 3..2 * n / 3].fill(0);
        assert!(check(&zeroed).is_err());
        // Without its end.
        assert_eq!(
            check(&good[..n - 2]).unwrap_err(),
            "the file ends after the compressed data, without an end-of-image marker"
        );
        assert!(check(b"not a jpeg").is_err());
    }
}
