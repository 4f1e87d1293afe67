!> The seven bead models of the settlers paper as named presets: the parameters of the
!> appendix "Bead model of the particles used in the experiments" and the paper's L/d
!> (Table tab_mob_num), the length that makes the mobilities dimensionless.
!> How each value follows from the paper is documented in shapes/README.md.
module beadmob_paper_presets
  use beadmob_kinds, only: dp
  use beadmob_paper_shapes, only: paper_cone_base_diameter, paper_cone_height, paper_arrowhead_length, &
    paper_arrowhead_height, paper_arrowhead_middle_height, paper_arrowhead_width, paper_ring_semi_major, &
    paper_ring_semi_minor, paper_ring_gap_half_angle_deg, paper_ring_pipe_radius, paper_crescent_scale, &
    paper_crescent_section_ratio, paper_cone_reference_length, paper_arrowhead_reference_length, &
    paper_crescent_reference_length, paper_ring_reference_length
  implicit none
  private
  public :: paper_shape_t, paper_shape_preset

  type :: paper_shape_t
    real(dp) :: reference_length = 0.0_dp
    real(dp) :: base_diameter = 0.0_dp, height = 0.0_dp
    real(dp) :: length = 0.0_dp, middle_height = 0.0_dp, width = 0.0_dp
    real(dp) :: semi_major = 0.0_dp, semi_minor = 0.0_dp, pipe_radius = 0.0_dp, gap_half_angle = 0.0_dp
    real(dp) :: scale = 0.0_dp, section_ratio = 0.0_dp
  end type paper_shape_t

contains

  !> Parameters of a preset in units of the bead diameter; 'open_ring' has none (all required).
  pure function paper_shape_preset(name) result(preset)
    character(len=*), intent(in) :: name
    type(paper_shape_t) :: preset
    integer :: ring
    select case (name)
    case ('cone')
      preset = paper_shape_t(reference_length=paper_cone_reference_length, base_diameter=paper_cone_base_diameter, &
                             height=paper_cone_height)
    case ('arrowhead')
      preset = paper_shape_t(reference_length=paper_arrowhead_reference_length, length=paper_arrowhead_length, &
                             height=paper_arrowhead_height, middle_height=paper_arrowhead_middle_height, &
                             width=paper_arrowhead_width)
    case ('crescent_moon')
      preset = paper_shape_t(reference_length=paper_crescent_reference_length, scale=paper_crescent_scale, &
                             section_ratio=paper_crescent_section_ratio)
    case ('ring_1mm', 'ring_2mm', 'ring_3mm', 'ring_4mm')
      ring = iachar(name(6:6)) - iachar('0')
      preset = paper_shape_t(reference_length=paper_ring_reference_length(ring), &
                             semi_major=paper_ring_semi_major(ring), semi_minor=paper_ring_semi_minor(ring), &
                             pipe_radius=paper_ring_pipe_radius, gap_half_angle=paper_ring_gap_half_angle_deg(ring))
    end select
  end function paper_shape_preset
end module beadmob_paper_presets
