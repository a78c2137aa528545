//! The filters' small products, written so that each sum keeps its bits: `oe`'s
//! simulation and `pem`'s predictor step every state at every instant, so these are among
//! the fits' innermost loops.

/// acc_c += Σ_l M_cl v_l for every row c of the row-major R × v.len() matrix `matrix`:
/// the terms are added in l's order to all R sums at once. Each row's sum is the same
/// operations in the same order as that row summed on its own (the same bits), but the
/// R sums are independent, in registers where R is known when compiled, where one row
/// after another would be a chain of adds each waiting on the last.
#[inline(always)]
pub(crate) fn add_matrix_vector<const R: usize>(acc: &mut [f64; R], matrix: &[f64], v: &[f64]) {
    let columns = v.len();
    for (l, &x) in v.iter().enumerate() {
        for (c, a) in acc.iter_mut().enumerate() {
            *a += matrix[c * columns + l] * x;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_sum_is_the_rows_own_to_the_bit() {
        // Terms of mixed size and sign, where the order of the adds shows in the last bit.
        let matrix = [
            1.0e16, 1.0, -1.0e16, 0.1, //
            0.3, 1.0e-8, 7.0, -2.5, //
            -1.0, 3.0e15, 1.0, 1.0e-3,
        ];
        let v = [1.0, 0.7, 1.0, -3.3];
        let mut acc = [0.5, -0.25, 2.0];
        add_matrix_vector(&mut acc, &matrix, &v);
        for (c, got) in acc.iter().enumerate() {
            let mut want = [0.5, -0.25, 2.0][c];
            for l in 0..4 {
                want += matrix[c * 4 + l] * v[l];
            }
            assert_eq!(got.to_bits(), want.to_bits(), "row {c}");
        }
        // Row 0 in l's order loses its 0.5 and 0.7 to the 1e16s, which then cancel: what
        // is left is the last term alone (summing the 1e16s first would keep them).
        assert_eq!(acc[0], 0.1 * -3.3);
    }
}
