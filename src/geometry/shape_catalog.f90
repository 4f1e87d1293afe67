!> From the &shape group of the input to a bead model: known shape names, their
!> parameters (required, optional with the paper's values, or not taken), and bead files.
module beadmob_shape_catalog
  use mpi, only: MPI_Bcast, MPI_INTEGER, MPI_DOUBLE_PRECISION
  use beadmob_kinds, only: dp
  use beadmob_errors, only: error_t, raise
  use beadmob_strings, only: str
  use beadmob_parallel, only: run_context_t, agree_on_error
  use beadmob_input_config, only: shape_config_t, is_set
  use beadmob_bead_model, only: bead_model_t, add_parameter
  use beadmob_paper_shapes, only: build_cone, build_arrowhead, build_open_ring, build_crescent_moon, &
                                  gap_half_angle_from_arc
  use beadmob_paper_presets, only: paper_shape_t, paper_shape_preset
  use beadmob_simple_shapes, only: build_single_bead, build_bead_pair, build_chain, build_filled_sphere, &
                                   build_spheroid, build_box, build_torus, build_solid_box, build_cylinder
  use beadmob_text_bead_file, only: read_text_bead_file
  use beadmob_hdf5_bead_file, only: read_hdf5_bead_file, is_hdf5_file
  use beadmob_triangle_mesh, only: triangle_mesh_t, read_triangle_mesh, check_closed_mesh, fill_mesh_on_lattice
  implicit none
  private
  public :: build_bead_model, known_shape_names, read_mesh_once, triangle_mesh_t

  character(len=*), parameter :: known_shape_names = 'cone, arrowhead, crescent_moon, ring_1mm, ring_2mm, ' // &
    'ring_3mm, ring_4mm, open_ring, single_bead, bead_pair, chain, sphere, spheroid, box, cylinder, torus, bead_file, mesh'

  !> One real parameter of the &shape group, by name, for the "given but not taken" check.
  type :: named_value_t
    character(len=32) :: name
    logical :: given
  end type named_value_t

contains

  !> `mesh`: for shape 'mesh', the file already read and checked by read_mesh_once (a job that
  !> fills one mesh many times reads it once); a fill without a node is then an empty model, as
  !> for the analytic shapes, and the caller judges it.
  subroutine build_bead_model(ctx, shape_config, model, err, mesh)
    type(run_context_t), intent(in) :: ctx
    type(shape_config_t), intent(in) :: shape_config
    type(bead_model_t), intent(out) :: model
    type(error_t), intent(inout) :: err
    type(triangle_mesh_t), intent(in), optional :: mesh
    character(len=:), allocatable :: name

    name = trim(shape_config%name)
    model%shape_name = name
    model%source = 'built-in shape'
    allocate (model%parameters(0))
    if (is_set(shape_config%reference_length)) then
      if (.not. (shape_config%reference_length > 0.0_dp)) then
        call raise(err, '&shape reference_length must be positive, got ' // str(shape_config%reference_length))
        return
      end if
    end if
    if (.not. all(shape_config%lattice_offset >= 0.0_dp .and. shape_config%lattice_offset < 1.0_dp)) then
      call raise(err, '&shape lattice_offset must be in [0, 1) (a fraction of d) on each axis, got ' // &
                 str(shape_config%lattice_offset(1)) // ', ' // str(shape_config%lattice_offset(2)) // ', ' // &
                 str(shape_config%lattice_offset(3)))
      return
    end if

    select case (name)
    case ('cone', 'arrowhead', 'crescent_moon', 'ring_1mm', 'ring_2mm', 'ring_3mm', 'ring_4mm', 'open_ring')
      call build_paper_shape(shape_config, model, err)
    case ('single_bead', 'bead_pair', 'chain', 'sphere', 'spheroid', 'box', 'cylinder', 'torus')
      call build_simple_shape(shape_config, model, err)
    case ('bead_file')
      call read_bead_file(ctx, shape_config, model, err)
    case ('mesh')
      call fill_mesh_file(ctx, shape_config, model, err, mesh)
    case default
      call raise(err, "unknown shape name '" // name // "' (known: " // known_shape_names // ')')
    end select
    if (err%failed) return
    if (any(shape_config%lattice_offset /= 0.0_dp)) then
      call add_parameter(model, 'lattice_offset_x', shape_config%lattice_offset(1))
      call add_parameter(model, 'lattice_offset_y', shape_config%lattice_offset(2))
      call add_parameter(model, 'lattice_offset_z', shape_config%lattice_offset(3))
    end if
    if (is_set(shape_config%reference_length)) then
      ! in the unit of the shape's lengths: d, or the unit bead_diameter is given in
      model%reference_length = shape_config%reference_length
      if (is_set(shape_config%bead_diameter)) model%reference_length = model%reference_length / shape_config%bead_diameter
    end if
  end subroutine build_bead_model

  !> The paper's shapes (settlers paper, appendix "Bead model ..."): every parameter defaults
  !> to the paper's value; L is the paper's L/d unless a parameter was changed. With
  !> bead_diameter, every length is given in its unit (size_of; length_unit).
  subroutine build_paper_shape(c, model, err)
    type(shape_config_t), intent(in) :: c
    type(bead_model_t), intent(inout) :: model
    type(error_t), intent(inout) :: err
    type(paper_shape_t) :: preset
    logical :: modified
    real(dp) :: gap_half_angle, per_d

    preset = paper_shape_preset(trim(c%name))
    gap_half_angle = preset%gap_half_angle
    ! In physical units (bead_diameter given) every length of the shape is given in that unit:
    ! the paper's defaults are in d and are not mixed in.
    call length_unit(c, model, per_d, err)
    if (err%failed) return
    select case (trim(c%name))
    case ('cone')
      call only_given(c, [character(len=32) :: 'base_diameter', 'height', 'bead_diameter', 'lattice_offset'], err)
      if (err%failed) return
      associate (base_diameter => size_of('base_diameter', c%base_diameter, preset%base_diameter), &
                 height => size_of('height', c%height, preset%height))
        if (err%failed) return
        call add_parameter(model, 'base_diameter', pick(c%base_diameter, preset%base_diameter))
        call add_parameter(model, 'height', pick(c%height, preset%height))
        call build_cone(base_diameter, height, model%centres, err, c%lattice_offset)
      end associate
    case ('arrowhead')
      call only_given(c, [character(len=32) :: 'length', 'height', 'middle_height', 'width', 'bead_diameter', &
                                               'lattice_offset'], err)
      if (err%failed) return
      associate (length => size_of('length', c%length, preset%length), height => size_of('height', c%height, preset%height), &
                 middle_height => size_of('middle_height', c%middle_height, preset%middle_height), &
                 width => size_of('width', c%width, preset%width))
        if (err%failed) return
        call add_parameter(model, 'length', pick(c%length, preset%length))
        call add_parameter(model, 'height', pick(c%height, preset%height))
        call add_parameter(model, 'middle_height', pick(c%middle_height, preset%middle_height))
        call add_parameter(model, 'width', pick(c%width, preset%width))
        call build_arrowhead(length, height, middle_height, width, model%centres, err, c%lattice_offset)
      end associate
    case ('crescent_moon')
      call only_given(c, [character(len=32) :: 'scale', 'section_ratio', 'bead_diameter', 'lattice_offset'], err)
      if (err%failed) return
      associate (scale => size_of('scale', c%scale, preset%scale), section_ratio => pick(c%section_ratio, preset%section_ratio))
        if (err%failed) return
        call add_parameter(model, 'scale', pick(c%scale, preset%scale))
        call add_parameter(model, 'section_ratio', section_ratio)
        call build_crescent_moon(scale, section_ratio, model%centres, err, c%lattice_offset)
      end associate
    case default   ! open rings: the four presets and the generic 'open_ring'
      call only_given(c, [character(len=32) :: 'semi_major', 'semi_minor', 'pipe_radius', 'gap_half_angle', &
                                               'gap_arc_length', 'bead_diameter', 'lattice_offset'], err)
      if (err%failed) return
      if (trim(c%name) == 'open_ring') then
        call require(c, 'semi_major', c%semi_major, err)
        call require(c, 'semi_minor', c%semi_minor, err)
        call require(c, 'pipe_radius', c%pipe_radius, err)
        if (.not. (is_set(c%gap_half_angle) .or. is_set(c%gap_arc_length))) &
          call raise(err, "&shape: shape 'open_ring' needs gap_half_angle (degrees) or gap_arc_length (d)")
      end if
      if (is_set(c%gap_half_angle) .and. is_set(c%gap_arc_length)) &
        call raise(err, '&shape: give gap_half_angle or gap_arc_length, not both')
      if (err%failed) return
      associate (semi_major => size_of('semi_major', c%semi_major, preset%semi_major), &
                 semi_minor => size_of('semi_minor', c%semi_minor, preset%semi_minor), &
                 pipe_radius => size_of('pipe_radius', c%pipe_radius, preset%pipe_radius))
        if (err%failed) return
        gap_half_angle = pick(c%gap_half_angle, preset%gap_half_angle)
        if (is_set(c%gap_arc_length)) then
          if (.not. (c%gap_arc_length >= 0.0_dp)) then
            call raise(err, '&shape gap_arc_length must be >= 0, got ' // str(c%gap_arc_length))
            return
          end if
          gap_half_angle = gap_half_angle_from_arc(semi_major, semi_minor, c%gap_arc_length * per_d)
          call add_parameter(model, 'gap_arc_length', c%gap_arc_length)
        end if
        call add_parameter(model, 'semi_major', pick(c%semi_major, preset%semi_major))
        call add_parameter(model, 'semi_minor', pick(c%semi_minor, preset%semi_minor))
        call add_parameter(model, 'pipe_radius', pick(c%pipe_radius, preset%pipe_radius))
        call add_parameter(model, 'gap_half_angle', gap_half_angle)
        call build_open_ring(semi_major, semi_minor, pipe_radius, gap_half_angle, model%centres, err, &
                             c%lattice_offset)
      end associate
    end select
    ! L is the paper's L/d only for the paper's own parameters.
    modified = any([pick(c%base_diameter, preset%base_diameter) /= preset%base_diameter, &
                    pick(c%height, preset%height) /= preset%height, pick(c%length, preset%length) /= preset%length, &
                    pick(c%middle_height, preset%middle_height) /= preset%middle_height, &
                    pick(c%width, preset%width) /= preset%width, &
                    pick(c%semi_major, preset%semi_major) /= preset%semi_major, &
                    pick(c%semi_minor, preset%semi_minor) /= preset%semi_minor, &
                    pick(c%pipe_radius, preset%pipe_radius) /= preset%pipe_radius, &
                    gap_half_angle /= preset%gap_half_angle, pick(c%scale, preset%scale) /= preset%scale, &
                    pick(c%section_ratio, preset%section_ratio) /= preset%section_ratio]) .or. trim(c%name) == 'open_ring'
    if (.not. modified .and. .not. is_set(c%bead_diameter)) model%reference_length = preset%reference_length

  contains

    !> A length of the shape in d: the given value (times per_d), else the paper's; in physical
    !> units the value must be given.
    real(dp) function size_of(name, given, default)
      character(len=*), intent(in) :: name
      real(dp), intent(in) :: given, default
      size_of = pick(given, default)
      if (.not. is_set(c%bead_diameter)) return
      if (.not. is_set(given)) then
        call raise(err, "&shape: with bead_diameter, shape '" // trim(c%name) // "' needs " // name // &
                   ' in the same unit (the paper''s values are in d)')
        return
      end if
      size_of = given * per_d
    end function size_of
  end subroutine build_paper_shape

  !> sphere, spheroid and torus take their lengths in any unit with `bead_diameter` (d in that
  !> unit, the resolution; length_unit): the lattice body is the one of lengths / bead_diameter,
  !> and the bead centres fill it (docs/input.md, "Physical units"). The result file records the
  !> lengths as given and bead_diameter.
  subroutine build_simple_shape(c, model, err)
    type(shape_config_t), intent(in) :: c
    type(bead_model_t), intent(inout) :: model
    type(error_t), intent(inout) :: err
    integer :: k
    real(dp) :: per_d   ! lattice units (d) per given length unit
    call length_unit(c, model, per_d, err)
    if (err%failed) return
    select case (trim(c%name))
    case ('single_bead')
      call only_given(c, [character(len=32) :: ''], err)
      if (.not. err%failed) call build_single_bead(model%centres, err)
    case ('bead_pair')
      call only_given(c, [character(len=32) :: 'separation'], err)
      call require(c, 'separation', c%separation, err)
      if (err%failed) return
      call add_parameter(model, 'separation', c%separation)
      call build_bead_pair(c%separation, model%centres, err)
    case ('chain')
      call only_given(c, [character(len=32) :: 'n_beads'], err)
      if (.not. is_set(c%n_beads)) call raise(err, "&shape: shape 'chain' needs n_beads")
      if (err%failed) return
      call add_parameter(model, 'n_beads', real(c%n_beads, dp))
      call build_chain(c%n_beads, model%centres, err)
    case ('sphere')
      call only_given(c, [character(len=32) :: 'radius', 'bead_diameter', 'lattice_offset'], err)
      call require(c, 'radius', c%radius, err)
      if (err%failed) return
      call add_parameter(model, 'radius', c%radius)
      call build_filled_sphere(c%radius * per_d, model%centres, err, c%lattice_offset)
    case ('spheroid')
      call only_given(c, [character(len=32) :: 'semi_axes', 'bead_diameter', 'lattice_offset'], err)
      if (.not. all(is_set(c%semi_axes))) call raise(err, "&shape: shape 'spheroid' needs semi_axes = a, b, c")
      if (err%failed) return
      do k = 1, 3
        call add_parameter(model, 'semi_axis_' // achar(iachar('x') + k - 1), c%semi_axes(k))
      end do
      call build_spheroid(c%semi_axes * per_d, model%centres, err, c%lattice_offset)
    case ('box')
      if (any(is_set(c%box_size))) then   ! by its side lengths, in any unit
        call only_given(c, [character(len=32) :: 'box_size', 'bead_diameter', 'lattice_offset'], err)
        if (.not. all(is_set(c%box_size))) call raise(err, "&shape: shape 'box' needs box_size = lx, ly, lz (all three)")
        if (err%failed) return
        do k = 1, 3
          call add_parameter(model, 'size_' // achar(iachar('x') + k - 1), c%box_size(k))
        end do
        call build_solid_box(c%box_size * per_d, model%centres, err, c%lattice_offset)
        return
      end if
      call only_given(c, [character(len=32) :: 'box_beads'], err)
      if (.not. all(is_set(c%box_beads))) call raise(err, "&shape: shape 'box' needs box_beads = nx, ny, nz " // &
                                                     '(beads) or box_size = lx, ly, lz (lengths)')
      if (err%failed) return
      do k = 1, 3
        call add_parameter(model, 'beads_' // achar(iachar('x') + k - 1), real(c%box_beads(k), dp))
      end do
      call build_box(c%box_beads(1), c%box_beads(2), c%box_beads(3), model%centres, err)
    case ('cylinder')
      call only_given(c, [character(len=32) :: 'radius', 'length', 'bead_diameter', 'lattice_offset'], err)
      call require(c, 'radius', c%radius, err)
      call require(c, 'length', c%length, err)
      if (err%failed) return
      call add_parameter(model, 'radius', c%radius)
      call add_parameter(model, 'length', c%length)
      call build_cylinder(c%radius * per_d, c%length * per_d, model%centres, err, c%lattice_offset)
    case ('torus')
      call only_given(c, [character(len=32) :: 'major_radius', 'minor_radius', 'bead_diameter', 'lattice_offset'], err)
      call require(c, 'major_radius', c%major_radius, err)
      call require(c, 'minor_radius', c%minor_radius, err)
      if (err%failed) return
      call add_parameter(model, 'major_radius', c%major_radius)
      call add_parameter(model, 'minor_radius', c%minor_radius)
      call build_torus(c%major_radius * per_d, c%minor_radius * per_d, model%centres, err, c%lattice_offset)
    end select
  end subroutine build_simple_shape

  !> Bead files are read by rank 0 and broadcast: one reader, identical beads on all ranks.
  subroutine read_bead_file(ctx, c, model, err)
    type(run_context_t), intent(in) :: ctx
    type(shape_config_t), intent(in) :: c
    type(bead_model_t), intent(inout) :: model
    type(error_t), intent(inout) :: err
    integer :: n_beads, ierr
    logical :: hdf5_format

    call only_given(c, [character(len=32) :: 'file'], err)
    if (len_trim(c%file) == 0) call raise(err, "&shape: shape 'bead_file' needs file = 'path'")
    if (err%failed) return
    model%source = trim(c%file)
    if (ctx%rank == 0) then
      hdf5_format = is_hdf5_file(trim(c%file))
      if (hdf5_format) then
        call read_hdf5_bead_file(trim(c%file), trim(c%dataset), model%centres, err)
      else
        call read_text_bead_file(trim(c%file), model%centres, model%source_lines, err)
      end if
      n_beads = size(model%centres, 2)
    end if
    call agree_on_error(ctx, err)
    if (err%failed) return
    call MPI_Bcast(n_beads, 1, MPI_INTEGER, 0, ctx%comm, ierr)
    if (ctx%rank /= 0) allocate (model%centres(3, n_beads))
    if (n_beads > 0) call MPI_Bcast(model%centres, 3 * n_beads, MPI_DOUBLE_PRECISION, 0, ctx%comm, ierr)
  end subroutine read_bead_file

  !> A triangle mesh (STL or OBJ) filled on the bead lattice at d = bead_diameter (mesh units):
  !> read and checked by rank 0 (triangle_mesh.f90) unless `prepared` holds it already (from
  !> read_mesh_once), filled by rank 0, the beads broadcast.
  subroutine fill_mesh_file(ctx, c, model, err, prepared)
    type(run_context_t), intent(in) :: ctx
    type(shape_config_t), intent(in) :: c
    type(bead_model_t), intent(inout) :: model
    type(error_t), intent(inout) :: err
    type(triangle_mesh_t), intent(in), optional :: prepared
    type(triangle_mesh_t) :: mesh
    integer :: sizes(2), ierr   ! beads, triangles
    real(dp) :: per_d

    call only_given(c, [character(len=32) :: 'file', 'bead_diameter', 'lattice_offset'], err)
    if (len_trim(c%file) == 0) call raise(err, "&shape: shape 'mesh' needs file = 'path' (.stl or .obj)")
    call require(c, 'bead_diameter (the bead diameter in the mesh''s length unit)', c%bead_diameter, err)
    if (err%failed) return
    call length_unit(c, model, per_d, err)
    if (err%failed) return
    model%source = trim(c%file)
    if (ctx%rank == 0) then
      if (present(prepared)) then
        call fill_mesh_on_lattice(prepared, per_d, trim(c%file), model%centres, err, c%lattice_offset)
        if (.not. err%failed) sizes = [size(model%centres, 2), size(prepared%triangles, 2)]
      else
        call read_triangle_mesh(trim(c%file), mesh, err)
        if (.not. err%failed) call check_closed_mesh(mesh, trim(c%file), err)
        if (.not. err%failed) call fill_mesh_on_lattice(mesh, per_d, trim(c%file), model%centres, err, &
                                                                      c%lattice_offset)
        if (.not. err%failed) then
          if (size(model%centres, 2) == 0) call raise(err, "mesh file '" // trim(c%file) // &
            "': no lattice node inside at bead_diameter = " // str(c%bead_diameter) // ' (a finer resolution is needed)')
          sizes = [size(model%centres, 2), size(mesh%triangles, 2)]
        end if
      end if
    end if
    call agree_on_error(ctx, err)
    if (err%failed) return
    call MPI_Bcast(sizes, 2, MPI_INTEGER, 0, ctx%comm, ierr)
    call add_parameter(model, 'triangles', real(sizes(2), dp))
    if (ctx%rank /= 0) allocate (model%centres(3, sizes(1)))
    call MPI_Bcast(model%centres, 3 * sizes(1), MPI_DOUBLE_PRECISION, 0, ctx%comm, ierr)
  end subroutine fill_mesh_file

  !> Collective. The mesh of shape 'mesh' read and checked to bound a solid, on rank 0 (the
  !> other ranks get an empty one): for build_bead_model's `mesh`, so a job of many fills reads
  !> a large file once.
  subroutine read_mesh_once(ctx, c, mesh, err)
    type(run_context_t), intent(in) :: ctx
    type(shape_config_t), intent(in) :: c
    type(triangle_mesh_t), intent(out) :: mesh
    type(error_t), intent(inout) :: err
    if (ctx%rank == 0) then
      call read_triangle_mesh(trim(c%file), mesh, err)
      if (.not. err%failed) call check_closed_mesh(mesh, trim(c%file), err)
    else
      allocate (mesh%vertices(3, 0), mesh%triangles(3, 0))
    end if
    call agree_on_error(ctx, err)
  end subroutine read_mesh_once

  !> per_d: lattice units (d) per unit of the shape's lengths: 1, or 1 / bead_diameter when it
  !> is given (then checked and recorded with the shape's parameters).
  subroutine length_unit(c, model, per_d, err)
    type(shape_config_t), intent(in) :: c
    type(bead_model_t), intent(inout) :: model
    real(dp), intent(out) :: per_d
    type(error_t), intent(inout) :: err
    per_d = 1.0_dp
    if (.not. is_set(c%bead_diameter)) return
    if (.not. (c%bead_diameter > 0.0_dp .and. c%bead_diameter < huge(1.0_dp))) then
      call raise(err, '&shape: bead_diameter must be positive and finite, got ' // str(c%bead_diameter))
      return
    end if
    per_d = 1.0_dp / c%bead_diameter
    call add_parameter(model, 'bead_diameter', c%bead_diameter)
  end subroutine length_unit

  elemental real(dp) function pick(given, default)
    real(dp), intent(in) :: given, default
    pick = merge(given, default, is_set(given))
  end function pick

  subroutine require(c, name, value, err)
    type(shape_config_t), intent(in) :: c
    character(len=*), intent(in) :: name
    real(dp), intent(in) :: value
    type(error_t), intent(inout) :: err
    if (.not. is_set(value)) call raise(err, "&shape: shape '" // trim(c%name) // "' needs " // name)
  end subroutine require

  !> A parameter given in &shape that the shape does not take is an error, not silently ignored.
  subroutine only_given(c, allowed, err)
    type(shape_config_t), intent(in) :: c
    character(len=*), intent(in) :: allowed(:)
    type(error_t), intent(inout) :: err
    type(named_value_t) :: given(23)
    integer :: k
    given = [named_value_t('base_diameter', is_set(c%base_diameter)), named_value_t('height', is_set(c%height)), &
             named_value_t('length', is_set(c%length)), named_value_t('middle_height', is_set(c%middle_height)), &
             named_value_t('width', is_set(c%width)), named_value_t('semi_major', is_set(c%semi_major)), &
             named_value_t('semi_minor', is_set(c%semi_minor)), named_value_t('pipe_radius', is_set(c%pipe_radius)), &
             named_value_t('gap_half_angle', is_set(c%gap_half_angle)), &
             named_value_t('gap_arc_length', is_set(c%gap_arc_length)), named_value_t('scale', is_set(c%scale)), &
             named_value_t('section_ratio', is_set(c%section_ratio)), &
             named_value_t('separation', is_set(c%separation)), named_value_t('radius', is_set(c%radius)), &
             named_value_t('major_radius', is_set(c%major_radius)), &
             named_value_t('minor_radius', is_set(c%minor_radius)), &
             named_value_t('semi_axes', any(is_set(c%semi_axes))), named_value_t('n_beads', is_set(c%n_beads)), &
             named_value_t('box_beads', any(is_set(c%box_beads))), named_value_t('file', len_trim(c%file) > 0), &
             named_value_t('bead_diameter', is_set(c%bead_diameter)), &
             named_value_t('lattice_offset', any(c%lattice_offset /= 0.0_dp)), &
             named_value_t('box_size', any(is_set(c%box_size)))]
    do k = 1, size(given)
      if (given(k)%given .and. .not. any(allowed == given(k)%name)) then
        call raise(err, "&shape: parameter '" // trim(given(k)%name) // "' is not taken by shape '" // &
                   trim(c%name) // "'")
        return
      end if
    end do
  end subroutine only_given
end module beadmob_shape_catalog
